// `mlp tool render-texture` and `mlp tool relocate`: an EDM electrode's surface texture in
// reflected light at the C axis' steps (the virtual camera), and the electrode found again
// after re-clamping from it (seed 000 example 6, relocate.h). The images' folder is a tool
// camera's (images.json, mlprobe-tool-images/1): the C axis' turn in whole degrees is each
// image's position of 360, the strobe's speed 0 (the axis stands still for each image).

#include "mlp/base/args.h"
#include "mlp/base/files.h"
#include "mlp/base/units.h"
#include "mlp/host/cli.h"
#include "mlp/toolcam/relocate.h"
#include "mlp/toolcam/tool_images.h"
#include "mlp/toolcam/tool_images_io.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iomanip>

#include "tool_commands.h"
#include <nlohmann/json.hpp>

namespace mlp::host::tool {
namespace {

constexpr int kTurnPositions = 360;  // a turn's positions in the manifest: whole degrees

geometry::Vec3 Triple(const Args& a, const std::string& name) {
  if (!a.Has(name)) return {0, 0, 0};
  const std::vector<double> v = base::ParseNumberList(name, a.Text(name));
  if (v.size() != 3) throw UsageError(name + " takes three numbers: x,y,z");
  return {v[0], v[1], v[2]};
}

// The reflected-light camera `render-texture` draws with: 512 x 512 px at 5 um, the spindle
// axis in the middle, the image's bottom 0.3 mm above the electrode's end.
toolcam::TextureCamera DefaultTextureCamera() {
  toolcam::TextureCamera c;
  c.geometry.width_px = 512, c.geometry.height_px = 512, c.geometry.mm_per_px = 0.005;
  c.geometry.axis_u_px = 255.5, c.geometry.tip_v_px = 511.5 + 0.3 / 0.005;
  c.geometry.distortion_k1 = 0, c.geometry.drops_per_frame = 0;
  return c;
}

std::vector<double> TurnsOf(const toolcam::ToolImageSeries& s) {
  std::vector<double> turns;
  for (int p : s.position) turns.push_back(360.0 * p / s.positions);
  return turns;
}

}  // namespace

int RenderTexture(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a(args, {{"--tool", "--out", "--turns-deg", "--rotation-deg", "--shift-mm", "--seed",
                       "--texture-seed"},
                      {}});
  if (a.Text("--tool", "").empty() || a.Text("--out", "").empty())
    throw UsageError("mlp tool render-texture needs --tool and --out");
  const toolcam::ToolDescription e = toolcam::LoadTool(a.Text("--tool"));
  const std::vector<double> turns =
      base::ParseNumberList("--turns-deg", a.Text("--turns-deg", "0,90,180,270"));
  toolcam::ClampPose pose;
  pose.rotation_rad = Triple(a, "--rotation-deg") / base::kDegPerRad;
  pose.translation_mm = Triple(a, "--shift-mm");
  toolcam::TextureCamera camera = DefaultTextureCamera();
  camera.texture_seed = static_cast<unsigned>(a.Integer("--texture-seed", 1));
  std::mt19937 rng(static_cast<unsigned>(a.Integer("--seed", 1)));
  const std::string dir = a.Text("--out");
  std::filesystem::create_directories(dir);
  std::vector<std::string> files;
  std::vector<int> position;
  for (double t : turns) {
    if (!(t >= 0 && t < 360 && t == std::floor(t)))
      throw UsageError("--turns-deg takes whole degrees in [0, 360)");
    char name[32];
    std::snprintf(name, sizeof name, "texture_%03d.pgm", static_cast<int>(t));
    err << "mlp tool: rendering the texture at C " << t << " deg\n";
    toolcam::WritePgm((std::filesystem::path(dir) / name).string(), camera.geometry.width_px,
                      camera.geometry.height_px,
                      toolcam::RenderTextureFrame(e, pose, t / base::kDegPerRad, camera, rng));
    files.emplace_back(name), position.push_back(static_cast<int>(t));
  }
  toolcam::StrobePlan still;  // the C axis stands for each image
  still.rpm = 0, still.positions = kTurnPositions, still.pulse_width_us = 0;
  base::WriteFileAtomically((std::filesystem::path(dir) / "images.json").string(),
                            toolcam::ToolImagesJson(camera.geometry, still, {}, files, position));
  const nlohmann::json truth = {
      {"format", "mlprobe-texture-truth/1"},
      {"tool", e.id},
      {"rotation_deg",
       {pose.rotation_rad.x() * base::kDegPerRad, pose.rotation_rad.y() * base::kDegPerRad,
        pose.rotation_rad.z() * base::kDegPerRad}},
      {"shift_mm", {pose.translation_mm.x(), pose.translation_mm.y(), pose.translation_mm.z()}},
      {"texture_seed", camera.texture_seed}};
  base::WriteFileAtomically((std::filesystem::path(dir) / "truth.json").string(),
                            truth.dump(1) + "\n");
  out << files.size() << " images and truth.json in " << dir << "\n";
  return kExitOk;
}

int Relocate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a(args, {{"--reference", "--images", "--tool", "--max-tilt-deg"}, {"--json"}});
  if (a.Text("--reference", "").empty() || a.Text("--images", "").empty() ||
      a.Text("--tool", "").empty())
    throw UsageError("mlp tool relocate needs --reference, --images and --tool");
  const double max_tilt_deg = a.Number("--max-tilt-deg", 0.01);
  const toolcam::ToolDescription e = toolcam::LoadTool(a.Text("--tool"));
  const toolcam::ToolImageSeries ref = toolcam::ReadToolImageSeries(a.Text("--reference"));
  const toolcam::ToolImageSeries now = toolcam::ReadToolImageSeries(a.Text("--images"));
  if (!ref.calibrated || !now.calibrated)
    throw base::InputError("relocate: the manifests must hold the camera's calibration");
  err << "mlp tool: relocating " << e.id << " from " << now.pixels.size() << " images\n";
  const std::vector<double> ref_turns = TurnsOf(ref), now_turns = TurnsOf(now);
  const toolcam::Relocation r = toolcam::Relocate({ref.pixels, ref_turns, ref.camera},
                                                  {now.pixels, now_turns, now.camera}, e);
  const geometry::Vec3& t = r.change.translation_mm;
  const bool tilt_ok = r.tilt_deg <= max_tilt_deg;
  if (a.Has("--json")) {
    out << nlohmann::json{{"tool", e.id},
                          {"rotation_deg",
                           {r.rotation_deg[0], r.rotation_deg[1], r.rotation_deg[2]}},
                          {"shift_mm", {t.x(), t.y(), t.z()}},
                          {"c_deg", r.rotation_deg[2]},
                          {"tilt_deg", r.tilt_deg},
                          {"max_tilt_deg", max_tilt_deg},
                          {"accept", tilt_ok},
                          {"rms_um", r.rms_um},
                          {"patches", r.patches},
                          {"left_out", r.left_out}}
               .dump()
        << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(2) << "electrode " << e.id
      << " against its reference: its end moved X " << t.x() * 1e3 << ", Y " << t.y() * 1e3
      << ", Z " << t.z() * 1e3 << " um, turned C " << std::setprecision(4) << r.rotation_deg[2]
      << " deg\n  tilt " << r.tilt_deg << " deg (about x " << r.rotation_deg[0] << ", about y "
      << r.rotation_deg[1] << "), limit " << max_tilt_deg << ": "
      << (tilt_ok ? "accept (X, Y, Z, C correct the rest)" : "REJECT: clamp it again") << "\n  "
      << r.patches << " patches, " << r.left_out << " left out, rms " << std::setprecision(3)
      << r.rms_um << " um\n";
  return kExitOk;
}

}  // namespace mlp::host::tool
