#include "calibrate_optics.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/calib/board_views.h"
#include "mlp/calib/camera_json.h"
#include "mlp/calib/capture_io.h"
#include "mlp/calib/probe_calib.h"
#include "mlp/host/cli.h"
#include "mlp/probe_fw/probe_model.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>

#include "format_numbers.h"
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;
using geometry::Vec3;

// Above these the fit is suspect (a wrong board size, a blurred view, stripes on checker
// edges): the result is written but the summary says so. The virtual probe at nominal noise
// gives 0.04 px and 0.02 columns.
constexpr double kSuspectCornerRmsPx = 0.3;
constexpr double kSuspectStripeRmsColumns = 0.15;

struct Options {
  std::string command, views, design, out, id;
  bool json = false;
};

Options Parse(const std::vector<std::string>& args) {
  const Args a({args.begin() + 1, args.end()},
               {{"--views", "--design", "--out", "--id"}, {"--json"}});
  Options o;
  o.command = args.at(0);
  o.views = a.Text("--views", "");
  o.design = a.Text("--design", "");
  o.out = a.Text("--out", "");
  o.id = a.Text("--id", "");
  o.json = a.Has("--json");
  if (o.views.empty()) throw UsageError("--views MANIFEST is required");
  if (o.command == "projector" && (o.design.empty() || o.out.empty()))
    throw UsageError("projector needs --design PROBE_FILE and --out PROBE_FILE");
  if (o.command == "camera" && (!o.design.empty() || !o.id.empty()))
    throw UsageError("camera takes --views, --out and --json only");
  if (!o.out.empty() && fs::exists(o.out))
    throw UsageError(o.out + " exists: calibrations are never overwritten; choose a new file");
  return o;
}

std::vector<calib::GrayImage> Leds(const calib::BoardViews& v) {
  std::vector<calib::GrayImage> out;
  for (const auto& view : v.views) out.push_back(view.led);
  return out;
}

void PrintIntrinsics(std::ostream& out, const calib::Intrinsics& k, const calib::Intrinsics* sd) {
  const auto pm = [&](double v, double s, int digits) {
    return Fixed(v, digits) + (sd ? " +- " + Fixed(s, digits) : std::string());
  };
  const calib::Intrinsics z;
  const calib::Intrinsics& s = sd ? *sd : z;
  out << "  fx " << pm(k.fx_px, s.fx_px, 2) << " px, fy " << pm(k.fy_px, s.fy_px, 2) << " px\n"
      << "  cx " << pm(k.cx_px, s.cx_px, 2) << " px, cy " << pm(k.cy_px, s.cy_px, 2) << " px\n"
      << "  k1 " << pm(k.k1, s.k1, 5) << ", k2 " << pm(k.k2, s.k2, 5) << ", k3 "
      << pm(k.k3, s.k3, 5) << "\n"
      << "  p1 " << pm(k.p1, s.p1, 6) << ", p2 " << pm(k.p2, s.p2, 6) << "\n";
}

int Camera(const Options& o, std::ostream& out, std::ostream& err) {
  err << "mlp calibrate: reading the views of " << o.views << "\n";
  const calib::BoardViews v = calib::LoadBoardViews(o.views, false);
  err << "mlp calibrate: camera calibration from " << v.views.size() << " LED frames\n";
  const calib::CameraCalibration c = calib::CalibrateCamera(Leds(v), v.board);
  const json j = calib::CameraFileJson(v, c);
  if (!o.out.empty()) WriteOutputFile(o.out, j.dump(2) + "\n");
  if (o.json) {
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  out << "camera calibration of probe " << v.probe_serial << ": board found in "
      << c.views_used.size() << " of " << v.views.size() << " views, reprojection RMS "
      << Fixed(c.rms_reprojection_px, 4) << " px\n";
  PrintIntrinsics(out, c.intrinsics, &c.std_dev);
  for (const auto& w : c.warnings) out << "  warning: " << w << "\n";
  if (c.rms_reprojection_px > kSuspectCornerRmsPx)
    out << "  check: reprojection RMS above " << kSuspectCornerRmsPx
        << " px (board size right? views sharp?)\n";
  if (!o.out.empty()) out << "  written to " << o.out << "\n";
  return kExitOk;
}

json ProjectorJson(const probe_fw::ProbeModel& m,
                   const calib::ProbeCalibReport& r,
                   const calib::BoardViews& v,
                   const std::string& path) {
  json j;
  j["probe_model"] = path;
  j["calibration_id"] = m.calibration_id;
  j["probe_serial"] = m.serial;
  j["views"] = calib::BoardViewsJson(v, r.camera_start);
  j["corners_used"] = r.result.corners_used;
  j["stripe_points"] = {{"found", r.stripes_found},
                        {"on_uniform_light", r.stripes_on_light},
                        {"used", r.result.stripes_used},
                        {"stride", r.stripe_stride}};
  j["corner_rms_px"] = r.result.corner_rms_px;
  j["stripe_rms_columns"] = r.result.stripe_rms_columns;
  j["camera"] = calib::IntrinsicsJson(r.result.camera);
  j["projector"] = {{"f_px", r.result.projector.f_px},
                    {"c_px", r.result.projector.c_px},
                    {"camera_from_projector",
                     base::json_fields::PoseToJson(r.result.projector.camera_from_projector)},
                    {"mirror_cubic_cols", r.result.projector.mirror_cubic_cols},
                    {"mirror_cubic_std_cols", r.result.mirror_cubic_std_cols},
                    {"sheet_smile_cols", r.result.projector.sheet_smile_cols},
                    {"sheet_smile_std_cols", r.result.smile_std_cols}};
  j["notes"] = r.result.notes;
  j["iterations"] = r.result.iterations;
  return j;
}

void PrintProjector(std::ostream& out,
                    const probe_fw::ProbeModel& design,
                    const probe_fw::ProbeModel& m,
                    const calib::ProbeCalibReport& r,
                    const std::string& path) {
  const auto& res = r.result;
  out << "camera/projector calibration " << m.calibration_id << " of probe " << m.serial << "\n"
      << "  views " << res.views_used << " (board found), corners " << res.corners_used
      << ", corner RMS " << Fixed(res.corner_rms_px, 4) << " px\n"
      << "  stripe points " << r.stripes_found << " found, " << r.stripes_on_light
      << " on uniform light, " << res.stripes_used << " used; stripe RMS "
      << Fixed(res.stripe_rms_columns, 4) << " columns\n"
      << "  camera:\n";
  PrintIntrinsics(out, res.camera, nullptr);
  const geometry::Pose3 d =
      design.projector.camera_from_projector.inverse() * res.projector.camera_from_projector;
  const Eigen::AngleAxisd turn(d.linear());
  out << "  projector: f " << Fixed(res.projector.f_px, 2) << " px (design "
      << Fixed(design.projector.f_px, 2) << "), centre column " << Fixed(res.projector.c_px, 2)
      << " (design " << Fixed(design.projector.c_px, 2) << ")\n"
      << "  projector pose vs design: " << Vec(d.translation(), 3) << " mm, "
      << Fixed(turn.angle() * base::kDegPerRad, 4) << " deg\n"
      << "  mirror cubic " << Fixed(res.projector.mirror_cubic_cols, 3) << " +- "
      << Fixed(res.mirror_cubic_std_cols, 3) << " columns, sheet smile "
      << Fixed(res.projector.sheet_smile_cols, 3) << " +- " << Fixed(res.smile_std_cols, 3)
      << " columns at the field's edge\n";
  for (const auto& w : r.camera_start.warnings) out << "  warning: " << w << "\n";
  for (const auto& n : res.notes) out << "  note: " << n << "\n";
  if (res.corner_rms_px > kSuspectCornerRmsPx || res.stripe_rms_columns > kSuspectStripeRmsColumns)
    out << "  check: residuals above " << kSuspectCornerRmsPx << " px / "
        << kSuspectStripeRmsColumns << " columns (board size, focus, design file right?)\n";
  out << "  probe model written to " << path << "\n";
}

int Projector(const Options& o, std::ostream& out, std::ostream& err) {
  const probe_fw::ProbeModel design = probe_fw::LoadProbeModel(o.design);
  err << "mlp calibrate: reading the views of " << o.views << "\n";
  const calib::BoardViews v =
      calib::LoadBoardViews(o.views, true, design.camera.width_px, design.camera.height_px);
  if (v.probe_serial != design.serial)
    throw UsageError("the views are of probe " + v.probe_serial + ", the design file is for " +
                     design.serial);
  std::vector<calib::StripeObservation> stripes;
  for (const auto& view : v.views)
    stripes.insert(stripes.end(), view.stripes.begin(), view.stripes.end());
  const auto start = std::chrono::steady_clock::now();
  const calib::ProbeCalibReport r =
      calib::CalibrateProbe(Leds(v), stripes, v.board, design, [&](const std::string& line) {
        err << "mlp calibrate: " << line << "\n" << std::flush;
      });
  err << "mlp calibrate: adjusted in "
      << Fixed(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1)
      << " s\n";
  const probe_fw::ProbeModel m = calib::CalibratedProbeModel(
      design, r.result, o.id.empty() ? DefaultCalibrationId(design.serial, "optics") : o.id);
  probe_fw::SaveProbeModel(m, o.out);
  if (o.json)
    out << ProjectorJson(m, r, v, o.out).dump(2) << "\n";
  else
    PrintProjector(out, design, m, r, o.out);
  return kExitOk;
}

}  // namespace

int RunCameraProjectorCommand(const std::vector<std::string>& args,
                              std::ostream& out,
                              std::ostream& err) {
  const Options o = Parse(args);
  return o.command == "camera" ? Camera(o, out, err) : Projector(o, out, err);
}

}  // namespace mlp::host
