#include "sim_command.h"

#include "mlp/base/input_error.h"
#include "mlp/base/json_fields.h"
#include "mlp/link/wire.h"
#include "mlp/probe_fw/cloud_io.h"
#include "mlp/probe_fw/frame_io.h"
#include "mlp/sim/render.h"

#include <chrono>
#include <cstdio>
#include <fstream>

#include "cli.h"

namespace mlp::sim {
namespace {

using probe_fw::cli::UsageError;

constexpr const char* kUsage =
    "usage: mlp-sim render --probe PROBE_FILE --scene SCENE_FILE --out DIR [--seed N]\n"
    "                      [--capture ID] [--aoi X0,Y0,W,H|full] [--columns FIRST:LAST:STEP]\n"
    "                      [--format png|pgm] [--noiseless] [--json]\n"
    "                      [--column-count N] [--led-supersampling N]\n"
    "  --probe     the probe the frames come from: a probe model file, or an as-built file\n"
    "              (mlprobe-as-built/1: the probe as it really is, which only the renderer reads)\n"
    "  --capture   which capture of the scene (default: the first)\n"
    "  --aoi       sensor window read out, or full (default: 512 x 512 at the centre)\n"
    "  --columns   laser sweep in projector columns (default: every 2nd column reaching the AOI)\n"
    "  --column-count  N columns evenly over those reaching the workpiece seen in the AOI\n"
    "              (calibration views: a 17 x 17 lattice of rays finds a small board)\n"
    "  --led-supersampling  N x N rays per LED pixel on edges (calibration targets' corners)\n"
    "writes DIR/frames.json, DIR/led.*, DIR/laser_NNNN.*, DIR/truth.json, DIR/truth_surface.ply\n"
    "exit codes: 0 written, 2 bad arguments or input, 1 bug\n"
    "\n"
    "usage: mlp-sim serve --probe PROBE_FILE --scene SCENE_FILE --port N --key KEY_FILE\n"
    "                     [--host ADDRESS] [--seed N] [--buffer CLOUDS] [--captures N]\n"
    "                     [--firmware-model PROBE_FILE] [--machine MACHINE_FILE]\n"
    "  a virtual probe: connects to the host's probe link, answers capture requests at the\n"
    "  requested pose, AOI and sweep until SIGINT/SIGTERM (or after N captures, acknowledged)\n"
    "  --firmware-model  the probe model its firmware triangulates with (required when --probe\n"
    "              is an as-built file; default: the --probe model file)\n"
    "  --machine   the trunnion the scene sits on, as it truly is (mlprobe-machine/1: its A and\n"
    "              C axes' lines): each capture is rendered where the running LinuxCNC's joints\n"
    "              (HAL, halcmd) put the probe on the table, whatever H the host sent\n"
    "exit codes: 0 stopped, 2 bad arguments or input (key file, probe, scene), 1 bug\n";

const Capture& FindCapture(const Scene& scene, const std::string& id) {
  if (id.empty()) return scene.captures.front();
  for (const Capture& c : scene.captures) {
    if (c.id == id) return c;
  }
  throw UsageError("the scene has no capture '" + id + "'");
}

probe_fw::Aoi DefaultAoi(const probe_fw::CameraModel& camera) {
  const int w = std::min(512, camera.width_px), h = std::min(512, camera.height_px);
  return {(camera.width_px - w) / 2, (camera.height_px - h) / 2, w, h};
}

void WriteTruth(const std::string& dir,
                const VirtualProbe& probe,
                const Capture& capture,
                const SweepOptions& o,
                const RenderedCapture& r) {
  namespace jf = base::json_fields;
  nlohmann::ordered_json j;
  j["format"] = "mlprobe-truth/1";
  j["probe_serial"] = probe.model().serial;
  j["capture_id"] = capture.id;
  j["seed"] = o.seed;
  j["noise"] = o.noise;
  j["mcs_from_flange"] = jf::PoseToJson(capture.mcs_from_flange);
  j["flange_from_probe"] = jf::PoseToJson(probe.scene().flange_from_probe);
  j["mcs_from_probe"] = jf::PoseToJson(probe.McsFromProbe(capture));
  j["aoi"] = {o.aoi.x0, o.aoi.y0, o.aoi.width, o.aoi.height};
  j["columns"] = {o.first_column, o.last_column, o.column_step};
  std::vector<probe_fw::CloudPoint> surface;
  for (size_t i = 0; i < r.truth.size(); ++i) {
    if (!r.truth[i].hit || !r.truth[i].lit) continue;
    probe_fw::CloudPoint p;
    p.point_in_probe = r.truth[i].point_in_probe;
    p.quality = 1.0;
    surface.push_back(p);
  }
  j["surface_points"] = surface.size();
  j["surface_file"] = "truth_surface.ply";
  probe_fw::WriteCloudPly(dir + "/truth_surface.ply", surface,
                          {probe.model().serial, probe.model().calibration_id, capture.id});
  std::ofstream out(dir + "/truth.json", std::ios::trunc);
  out << j.dump(2) << "\n";
  if (!out) throw probe_fw::FrameIoError("frames: cannot write " + dir + "/truth.json");
}

// --seed, --noiseless, --led-supersampling and --exposure into the sweep.
void SweepSettings(const base::Args& o, SweepOptions* sweep) {
  const double seed = o.Number("--seed", 1.0);
  if (seed < 0 || seed != std::floor(seed) || seed > 9e15)
    throw UsageError("--seed is a whole number");
  sweep->seed = static_cast<std::uint64_t>(seed);
  sweep->noise = !o.Has("--noiseless");
  const double supersampling = o.Number("--led-supersampling", 1.0);
  if (supersampling != std::floor(supersampling) || supersampling < 1 || supersampling > 16)
    throw UsageError("--led-supersampling is a whole number from 1 to 16");
  sweep->led_supersampling = static_cast<int>(supersampling);
  sweep->exposure = o.Number("--exposure", 1.0);
  if (!(sweep->exposure > 0.0 && sweep->exposure <= 1e4))
    throw UsageError("--exposure is a factor in (0, 10000] (1: the model's photometry)");
}

// The projector columns: --columns FIRST:LAST:STEP, or those reaching the AOI every 2 columns,
// or --column-count of them spread over the workpiece seen (calibration views).
void SweepColumns(const base::Args& o,
                  const VirtualProbe& probe,
                  const Capture& capture,
                  SweepOptions* sweep) {
  if (o.Has("--columns") && o.Has("--column-count"))
    throw UsageError("give --columns or --column-count, not both");
  if (o.Has("--columns")) {
    char c1 = 0, c2 = 0;
    const std::string text = o.Text("--columns", "");
    if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf", &sweep->first_column, &c1, &sweep->last_column,
                    &c2, &sweep->column_step) != 5 ||
        c1 != ':' || c2 != ':') {
      throw UsageError("--columns is FIRST:LAST:STEP, got '" + text + "'");
    }
    return;
  }
  // Calibration views (--column-count) spread their columns over the whole workpiece seen,
  // however small in the window: a 17 x 17 lattice of rays finds it.
  constexpr int kCalibrationGrid = 17;
  probe.ColumnsReaching(capture, sweep->aoi, &sweep->first_column, &sweep->last_column,
                        o.Has("--column-count") ? kCalibrationGrid : 3);
  sweep->column_step = 2.0;
  if (o.Has("--column-count")) {
    const double n = o.Number("--column-count", 0.0);
    if (n != std::floor(n) || n < 2 || n > 10000)
      throw UsageError("--column-count is a whole number from 2 to 10000");
    sweep->column_step = (sweep->last_column - sweep->first_column) / (n - 1);
  }
}

void PrintRendered(const base::Args& o,
                   const Capture& capture,
                   const SweepOptions& sweep,
                   size_t frames,
                   double seconds,
                   std::ostream& out) {
  const std::string dir = o.Text("--out");
  if (o.Has("--json")) {
    out << nlohmann::ordered_json{{"out", dir},
                                  {"capture_id", capture.id},
                                  {"frames", frames},
                                  {"aoi",
                                   {sweep.aoi.x0, sweep.aoi.y0, sweep.aoi.width, sweep.aoi.height}},
                                  {"seconds", seconds}}
               .dump(2)
        << "\n";
  } else {
    out << "mlp-sim: " << frames << " frames (1 LED, " << frames - 1
        << " laser) and ground truth -> " << dir << " in " << seconds << " s\n";
  }
}

int Render(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const base::Args o(args,
                     {{"--probe", "--scene", "--out", "--seed", "--capture", "--aoi", "--columns",
                       "--column-count", "--led-supersampling", "--format", "--exposure"},
                      {"--noiseless", "--json"}});
  const auto start = std::chrono::steady_clock::now();
  const VirtualProbe probe(LoadAsBuilt(o.Text("--probe")), LoadScene(o.Text("--scene")));
  const std::string dir = o.Text("--out");
  const std::string format = o.Text("--format", "png");
  if (format != "png" && format != "pgm") throw UsageError("--format is png or pgm");
  const Capture& capture = FindCapture(probe.scene(), o.Text("--capture", ""));
  SweepOptions sweep;
  const std::string aoi = o.Text("--aoi", "");
  sweep.aoi = aoi == "full" ? probe_fw::Aoi{0, 0, probe.model().camera.width_px,
                                            probe.model().camera.height_px}
              : aoi.empty() ? DefaultAoi(probe.model().camera)
                            : probe_fw::cli::ParseAoi(aoi);
  SweepSettings(o, &sweep);
  SweepColumns(o, probe, capture, &sweep);
  err << "mlp-sim: rendering capture '" << capture.id << "', AOI " << sweep.aoi.width << " x "
      << sweep.aoi.height << ", columns " << sweep.first_column << " to " << sweep.last_column
      << " step " << sweep.column_step << "\n";
  RenderedCapture r = probe.Render(capture, sweep);
  std::vector<probe_fw::Frame> frames{r.led};
  frames.insert(frames.end(), r.laser.begin(), r.laser.end());
  probe_fw::WriteCaptureDir(dir, {probe.model().serial, probe.model().calibration_id, capture.id},
                            frames, "." + format);
  WriteTruth(dir, probe, capture, sweep, r);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  PrintRendered(o, capture, sweep, frames.size(), seconds, out);
  return probe_fw::cli::kExitOk;
}

}  // namespace

int RunSimCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const bool serve = !args.empty() && args[0] == "serve";
  if (args.empty() || (args[0] != "render" && !serve)) {
    const bool help = !args.empty() && args[0] == "--help";
    (help ? out : err) << kUsage;
    return help ? probe_fw::cli::kExitOk : probe_fw::cli::kExitBadInput;
  }
  try {
    if (serve) return RunServeCommand({args.begin() + 1, args.end()}, out);
    return Render({args.begin() + 1, args.end()}, out, err);
  } catch (const UsageError& e) {
    err << "mlp-sim: " << e.what() << "\n" << kUsage;
    return probe_fw::cli::kExitBadInput;
  } catch (const base::InputError& e) {  // the probe model, the scene, the as-built file, frames
    err << "mlp-sim: " << e.what() << "\n";
    return probe_fw::cli::kExitBadInput;
  } catch (const link::LinkError& e) {  // a key file that is missing, unreadable or shared
    err << "mlp-sim: " << e.what() << "\n";
    return probe_fw::cli::kExitBadInput;
  } catch (const std::invalid_argument& e) {
    err << "mlp-sim: " << e.what() << "\n";
    return probe_fw::cli::kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp-sim: internal error: " << e.what() << "\n";
    return probe_fw::cli::kExitFailure;
  }
}

}  // namespace mlp::sim
