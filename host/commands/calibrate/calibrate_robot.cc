#include "calibrate_robot.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/calib/board_hand_eye.h"
#include "mlp/calib/camera_json.h"
#include "mlp/calib/line_laser.h"
#include "mlp/calib/record.h"
#include "mlp/calib/robot_views.h"
#include "mlp/host/calibrate_command.h"
#include "mlp/host/cli.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/triangulate.h"

#include <chrono>
#include <filesystem>
#include <map>
#include <ostream>
#include <stdexcept>

#include "format_numbers.h"
#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;
using geometry::Pose3;
using geometry::Vec3;

// Above this the mounting is refused: a robot cell's hand-eye, not a machine tool's (the
// sphere method's real-data test allows 1 mm; the blaser arm gives 0.07 mm).
constexpr double kDefaultMaxStdMm = 0.2;

struct Options {
  std::string command, views, design, probe, out, id, store, calibration, refined_probe;
  bool json = false, dry_run = false;
  calib::BoardHandEyeOptions hand_eye;
};

double PositiveNumber(const Args& a, const std::string& flag, double fallback) {
  const double v = a.Number(flag, fallback);
  if (!(v > 0)) throw UsageError(flag + " needs a positive number");
  return v;
}

void Require(bool ok, const char* what) {
  if (!ok) throw UsageError(what);
}

void CheckOptions(const Options& o) {
  Require(!o.views.empty(), "--views MANIFEST is required");
  if (o.command == "line-laser") {
    Require(!o.design.empty() && !o.out.empty(),
            "line-laser needs --design PROBE_FILE and --out PROBE_FILE");
    Require(o.probe.empty() && o.store.empty(), "line-laser takes --views --design --out --id");
  } else {
    Require(!o.probe.empty() && !o.store.empty(), "--probe PROBE_FILE and --store DIR are needed");
    Require(o.design.empty(), "--design is for line-laser");
  }
  if (o.command == "map") Require(!o.out.empty(), "map needs --out DIR (one cloud per image)");
  if (o.command == "board-pose") Require(o.out.empty(), "board-pose writes nothing: no --out");
  if (o.command != "board-hand-eye")
    Require(o.refined_probe.empty() && !o.dry_run,
            "--refined-probe and --dry-run are for board-hand-eye");
  if (o.command != "map" && o.command != "board-pose")
    Require(o.calibration.empty(), "--calibration is for map and board-pose");
  for (const std::string& file : {o.command == "map" ? std::string() : o.out, o.refined_probe})
    if (!file.empty() && fs::exists(file))
      throw UsageError(file + " exists: calibrations are never overwritten; choose a new file");
  if (o.command == "map" && fs::exists(o.out) && !fs::is_empty(o.out))
    throw UsageError(o.out + " exists and is not empty: clouds are never overwritten");
}

Options Parse(const std::vector<std::string>& args) {
  const Args a({args.begin() + 1, args.end()},
               {{"--views", "--design", "--probe", "--out", "--id", "--store", "--calibration",
                 "--refined-probe", "--max-std-mm", "--lever-mm"},
                {"--json", "--dry-run"}});
  Options o;
  o.command = args.at(0);
  o.views = a.Text("--views", "");
  o.design = a.Text("--design", "");
  o.probe = a.Text("--probe", "");
  o.out = a.Text("--out", "");
  o.id = a.Text("--id", "");
  o.store = a.Text("--store", "");
  o.calibration = a.Text("--calibration", "");
  o.refined_probe = a.Text("--refined-probe", "");
  o.json = a.Has("--json");
  o.dry_run = a.Has("--dry-run");
  o.hand_eye.max_std_mm = PositiveNumber(a, "--max-std-mm", kDefaultMaxStdMm);
  o.hand_eye.lever_mm = PositiveNumber(a, "--lever-mm", o.hand_eye.lever_mm);
  // The plane is refined with the hand-eye only when the refined probe model is written:
  // otherwise the firmware's file and the hand-eye would disagree about it.
  o.hand_eye.refine_plane = !o.refined_probe.empty();
  CheckOptions(o);
  return o;
}

// Every image, with a line of progress each (the images take a second or two each).
std::vector<calib::ImageFindings> Find(const calib::RobotViews& v, std::ostream& err) {
  size_t done = 0;
  return calib::FindInImages(v, [&](const std::string& line) {
    err << "mlp calibrate: [" << ++done << "/" << v.images.size() << "] " << line << "\n"
        << std::flush;
  });
}

json ImagesJson(const std::vector<calib::ImageFindings>& found) {
  json a = json::array();
  for (const auto& f : found) {
    json e = {{"name", f.name},
              {"board", f.HasBoard()},
              {"board_scale", f.corner_scale},
              {"stripe_points", f.stripe_px.size()},
              {"stripe_saturated", f.stripe_saturated}};
    if (!f.refused.empty()) e["refused"] = f.refused;
    a.push_back(e);
  }
  return a;
}

json PlaneJson(const calib::LineLaserCalibration& c) {
  return {{"normal_in_camera", {c.plane.normal.x(), c.plane.normal.y(), c.plane.normal.z()}},
          {"offset_mm", c.plane.normal.dot(c.plane.point)},
          {"rms_mm", c.plane_rms_mm},
          {"max_mm", c.plane_max_mm},
          {"points", c.plane_points},
          {"inliers", c.plane_inliers}};
}

int Refused(const std::vector<calib::ImageFindings>& found) {
  int n = 0;
  for (const auto& f : found) n += !f.refused.empty();
  return n;
}

int LineLaser(const Options& o, std::ostream& out, std::ostream& err) {
  const probe_fw::ProbeModel design = probe_fw::LoadProbeModel(o.design);
  const calib::RobotViews v = calib::LoadRobotViews(o.views);
  const auto found = Find(v, err);
  if (found.front().width_px != design.camera.width_px ||
      found.front().height_px != design.camera.height_px)
    throw UsageError("the images are " + std::to_string(found.front().width_px) + " x " +
                     std::to_string(found.front().height_px) + " px, the design's camera " +
                     std::to_string(design.camera.width_px) + " x " +
                     std::to_string(design.camera.height_px));
  const auto cal =
      calib::CalibrateLineLaser(found, v.board, design.camera.width_px, design.camera.height_px);
  const auto model = calib::LineLaserProbeModel(
      design, cal.camera.intrinsics, cal.plane,
      o.id.empty() ? DefaultCalibrationId(design.serial, "line-laser") : o.id);
  probe_fw::SaveProbeModel(model, o.out);
  json j = {{"probe_model", o.out},
            {"calibration_id", model.calibration_id},
            {"probe_serial", model.serial},
            {"images", ImagesJson(found)},
            {"boards_used", cal.board_images.size()},
            {"corner_rms_px", cal.camera.rms_reprojection_px},
            {"stripe_scatter_px", cal.scatter_rms_px},
            {"camera", calib::IntrinsicsJson(cal.camera.intrinsics)},
            {"plane", PlaneJson(cal)},
            {"notes", cal.notes}};
  if (o.json) {
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  out << "line-laser calibration " << model.calibration_id << " of " << model.serial << "\n"
      << "  images " << found.size() << ": board used in " << cal.board_images.size() << ", "
      << Refused(found) << " refused (neither board nor line)\n"
      << "  corners " << Fixed(cal.camera.rms_reprojection_px, 3) << " px RMS, stripe scatter "
      << Fixed(cal.scatter_rms_px, 3) << " px about a line\n"
      << "  light plane: " << Fixed(cal.plane_rms_mm, 4) << " mm RMS, "
      << Fixed(cal.plane_max_mm, 3) << " mm max (" << cal.plane_inliers << " of "
      << cal.plane_points << " points)\n";
  for (const auto& n : cal.notes) out << "  note: " << n << "\n";
  for (const auto& f : found)
    if (!f.refused.empty()) out << "  refused " << f.name << ": " << f.refused << "\n";
  out << "  probe model written to " << o.out << "\n";
  return kExitOk;
}

struct HandEyeFigures {
  calib::Spread corners, laser;
};

HandEyeFigures Figures(const calib::RobotViews& v,
                       const std::vector<calib::ImageFindings>& found,
                       const calib::LineLaserCalibration& cal,
                       const calib::BoardHandEyeResult& r) {
  HandEyeFigures f;
  std::vector<Pose3> flanges;
  for (int i : cal.board_images) flanges.push_back(v.images[size_t(i)].base_from_flange);
  f.corners = calib::CornerSpreadInBase(cal.camera.camera_from_board, flanges, r.flange_from_camera,
                                        v.board);
  std::vector<Vec3> in_base;
  for (size_t i = 0; i < found.size(); ++i) {
    const auto p = calib::LaserPointsInBase(found[i], v.images[i].base_from_flange,
                                            cal.camera.intrinsics, r.plane, r.flange_from_camera);
    in_base.insert(in_base.end(), p.begin(), p.end());
  }
  f.laser = calib::SpreadAboutCommonPlane(in_base);
  return f;
}

json SpreadJson(const calib::Spread& s) {
  json j = {
      {"rms_mm", s.rms_mm}, {"max_mm", s.max_mm}, {"points", s.points}, {"outliers", s.outliers}};
  if (s.threshold_mm > 0)  // a robust plane: its rule and every point's figures beside
    j.update({{"left_out_beyond_mm", s.threshold_mm},
              {"all_points", {{"rms_mm", s.all_rms_mm}, {"max_mm", s.all_max_mm}}}});
  return j;
}

// "0.220 mm RMS, 0.601 mm max over 6757 points (381 left out beyond 0.52 mm of the plane:
// 2.5 robust sigma); all 7138 points: 0.345 mm RMS, 2.57 mm max"
std::string SpreadText(const calib::Spread& s) {
  return Fixed(s.rms_mm, 3) + " mm RMS, " + Fixed(s.max_mm, 3) + " mm max over " +
         std::to_string(s.points) + " points (" + std::to_string(s.outliers) + " left out beyond " +
         Fixed(s.threshold_mm, 3) + " mm of the plane: 2.5 robust sigma); " + "all " +
         std::to_string(s.points + s.outliers) + " points: " + Fixed(s.all_rms_mm, 3) +
         " mm RMS, " + Fixed(s.all_max_mm, 3) + " mm max";
}

json HandEyeJson(const calib::BoardHandEyeResult& r, const HandEyeFigures& f) {
  json images = json::array();
  for (const auto& im : r.images)
    images.push_back({{"name", im.name},
                      {"robot_error_mm", im.robot_error_mm},
                      {"robot_error_deg", im.robot_error_deg},
                      {"corners", im.corners},
                      {"corner_rms_px", im.corner_rms_px},
                      {"laser_points", im.laser_points},
                      {"laser_rms_mm", im.laser_rms_mm},
                      {"laser_max_mm", im.laser_max_mm}});
  json sd = json::array();
  for (int i = 0; i < 6; ++i) sd.push_back(std::sqrt(r.covariance(i, i)));
  return {
      {"flange_from_probe", base::json_fields::PoseToJson(r.flange_from_camera)},
      {"start_flange_from_probe", base::json_fields::PoseToJson(r.start_flange_from_camera)},
      {"base_from_board", base::json_fields::PoseToJson(r.base_from_board)},
      {"std_dev",
       {{"parameters", {"rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm"}}, {"values", sd}}},
      {"worst_std_mm", r.worst_std_mm},
      {"corner_rms_px", r.corner_rms_px},
      {"noise",
       {{"corner_sigma_px", r.corner_sigma_px},
        {"laser_sigma_mm", r.laser_sigma_mm},
        {"robot_sigma_mm", r.robot_sigma_mm},
        {"robot_sigma_deg", r.robot_sigma_deg}}},
      {"corners_used", r.corners_used},
      {"laser_points_used", r.laser_points_used},
      {"corner_spread_in_base", SpreadJson(f.corners)},
      {"laser_points_about_common_plane", SpreadJson(f.laser)},
      {"images", images},
      {"warnings", r.warnings}};
}

void PrintHandEye(std::ostream& out,
                  const calib::BoardHandEyeResult& r,
                  const HandEyeFigures& f,
                  const calib::BoardHandEyeOptions& opt) {
  const Eigen::AngleAxisd turn(r.flange_from_camera.linear());
  out << "  flange_from_probe: t " << Vec(r.flange_from_camera.translation(), 3) << " mm, "
      << Fixed(turn.angle() * base::kDegPerRad, 4) << " deg\n"
      << "  determined to " << Fixed(r.worst_std_mm, 4) << " mm (1 sigma, worst combination, "
      << "rotations at " << Fixed(opt.lever_mm, 0) << " mm; limit " << opt.max_std_mm << ")\n"
      << "  corners through the robot's poses " << Fixed(r.corner_rms_px, 2)
      << " px RMS; noise found: corners " << Fixed(r.corner_sigma_px, 2) << " px, laser "
      << Fixed(r.laser_sigma_mm, 3) << " mm, the robot's poses " << Fixed(r.robot_sigma_mm, 3)
      << " mm / " << Fixed(r.robot_sigma_deg, 4) << " deg (1 sigma per axis)\n"
      << "  board corners in the base: " << Fixed(f.corners.rms_mm, 3) << " mm RMS, "
      << Fixed(f.corners.max_mm, 3) << " mm max from their mean\n"
      << "  laser points about one plane: " << SpreadText(f.laser) << "\n";
  out << "  per image: the robot's pose error the fit found [mm, deg]; corners off the solution "
         "through the reported pose [px RMS]; laser points' height above the board [mm RMS / "
         "max] (light beside the board counts)\n";
  for (const auto& im : r.images)
    if (im.corners > 0 || im.laser_points > 0)
      out << "    " << im.name << ": robot " << Fixed(im.robot_error_mm, 3) << " mm "
          << Fixed(im.robot_error_deg, 3) << " deg, corners "
          << (im.corners > 0 ? Fixed(im.corner_rms_px, 2) : std::string("-")) << ", laser "
          << (im.laser_points > 0 ? Fixed(im.laser_rms_mm, 3) + " / " + Fixed(im.laser_max_mm, 3)
                                  : std::string("-"))
          << "\n";
  for (const auto& w : r.warnings) out << "  warning: " << w << "\n";
}

int BoardHandEye(const Options& o, std::ostream& out, std::ostream& err) {
  const probe_fw::ProbeModel model = probe_fw::LoadProbeModel(o.probe);
  const calib::RobotViews v = calib::LoadRobotViews(o.views);
  const auto found = Find(v, err);
  const auto cal = calib::LineLaserOfModel(found, model, v.board);
  const auto start = std::chrono::steady_clock::now();
  const auto r = calib::SolveBoardHandEye(found, v.images, cal, v.board, o.hand_eye);
  err << "mlp calibrate: hand-eye solved in "
      << Fixed(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 2)
      << " s (" << r.variance_passes << " passes, " << r.iterations << " iterations)\n";
  const HandEyeFigures f = Figures(v, found, cal, r);
  std::vector<calib::RobotImage> used;
  for (size_t i = 0; i < found.size(); ++i)
    if (found[i].refused.empty()) used.push_back(v.images[i]);
  std::string id;
  if (!o.dry_run)
    id = calib::CalibrationStore(o.store).Save(calib::MakeRecord(model.serial, r, used));
  if (!o.refined_probe.empty() && !o.dry_run)
    probe_fw::SaveProbeModel(calib::LineLaserProbeModel(model, cal.camera.intrinsics, r.plane,
                                                        model.calibration_id + "+plane-" + id),
                             o.refined_probe);
  json j = HandEyeJson(r, f);
  j["calibration_id"] = id;
  j["probe_serial"] = model.serial;
  j["stored"] = !o.dry_run;
  if (o.json) {
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  out << "board hand-eye of " << model.serial << (o.dry_run ? " (dry run: nothing stored)" : "")
      << "\n";
  PrintHandEye(out, r, f, o.hand_eye);
  for (const auto& n : cal.notes) out << "  note: " << n << "\n";
  if (!o.dry_run) out << "  stored as " << id << " in " << o.store << "\n";
  if (!o.refined_probe.empty() && !o.dry_run)
    out << "  probe model with the refined plane written to " << o.refined_probe << "\n";
  return kExitOk;
}

// The image's stripe centres triangulated by the firmware with the probe model (column 0: the
// one light plane) and mapped by F_i X into the robot's base frame; the points' mean distance
// along the camera's axis in *mean_depth_mm (a near-range bias shows against it).
std::vector<Vec3> CloudInBase(const calib::ImageFindings& f,
                              const probe_fw::ProbeModel& model,
                              const Pose3& base_from_probe,
                              std::vector<float>* quality,
                              double* mean_depth_mm) {
  std::vector<Vec3> out;
  double depth = 0.0;
  for (size_t k = 0; k < f.stripe_px.size(); ++k) {
    // A ray in the light plane: no point.
    const auto& px = f.stripe_px[k];
    if (const auto p = probe_fw::Triangulate(model, px.x(), px.y(), 0.0)) {
      out.push_back(base_from_probe * *p);
      depth += p->z();
      quality->push_back(k < f.stripe_quality.size() ? f.stripe_quality[k] : 1.0f);
    }
  }
  *mean_depth_mm = out.empty() ? 0.0 : depth / static_cast<double>(out.size());
  return out;
}

// Flag rules for an image's cloud against the common plane: most of its stripe saturated (the
// centres of a clipped stripe are biased), its points as a whole off the plane the others
// share by more than the left-out threshold (a close-up, a pose error), or any of its points
// ten thresholds off (stray light: the held-out Blaser im25 has 7 points 46 mm off). Each
// image gets its figures over all its points; the flagged count is returned.
constexpr double kSaturatedShareFlag = 0.25;
constexpr double kFarPointThresholds = 10.0;

int JudgeImages(const calib::Spread& s,
                const std::vector<std::vector<Vec3>>& clouds,
                json* images) {
  int flagged = 0;
  for (size_t i = 0; i < clouds.size(); ++i) {
    json& e = (*images)[i];
    if (e.contains("refused")) continue;
    double sum = 0, sum2 = 0, worst = 0;
    int left_out = 0;
    for (const Vec3& p : clouds[i]) {
      const double d = s.plane.normal.dot(p - s.plane.point);
      sum += d, sum2 += d * d, worst = std::max(worst, std::abs(d));
      left_out += std::abs(d) > s.threshold_mm;
    }
    const double n = double(clouds[i].size());
    e["mean_mm"] = sum / n, e["rms_mm"] = std::sqrt(sum2 / n), e["max_mm"] = worst;
    e["left_out"] = left_out;
    std::string why;
    if (e["saturated_share"].get<double>() > kSaturatedShareFlag)
      why = Fixed(100 * e["saturated_share"].get<double>(), 0) +
            " % of the stripe saturated (those rows give no point)";
    if (std::abs(sum / n) > s.threshold_mm)
      why += (why.empty() ? "" : ", ") + std::string("its points ") + Fixed(sum / n, 2) +
             " mm off the plane the others share";
    if (worst > kFarPointThresholds * s.threshold_mm)
      why += (why.empty() ? "" : ", ") + std::string("points up to ") + Fixed(worst, 1) +
             " mm off the plane (stray light?)";
    if (why.empty()) continue;
    e["flag"] = why + ": retake it (less exposure, or check the robot's pose)";
    ++flagged;
  }
  return flagged;
}

// The line-laser probe model of --probe and its hand-eye: the latest, or --calibration's.
std::pair<probe_fw::ProbeModel, calib::CalibrationRecord> ModelAndHandEye(const Options& o) {
  probe_fw::ProbeModel model = probe_fw::LoadProbeModel(o.probe);
  if (model.projector.columns != 1)
    throw UsageError(o.probe + ": not a fixed line laser (projector.columns is not 1)");
  const calib::CalibrationStore store(o.store);
  const auto record = o.calibration.empty()
                          ? store.Latest(model.serial, calib::RecordKind::kHandEye)
                          : std::optional(store.Load(model.serial, o.calibration));
  if (!record) throw UsageError("probe " + model.serial + " has no hand-eye in " + o.store);
  return {std::move(model), *record};
}

// One image's line of map's printout.
void PrintMapImage(const json& e, std::ostream& out) {
  out << "    " << e["name"].get<std::string>() << ": ";
  if (e.contains("refused")) {
    out << e["refused"].get<std::string>() << "\n";
    return;
  }
  out << e["points"].get<size_t>() << " points, "
      << Fixed(100 * e["saturated_share"].get<double>(), 1) << " % of the stripe saturated, "
      << Fixed(e["mean_mm"].get<double>(), 3) << " mm off the plane on average, "
      << Fixed(e["rms_mm"].get<double>(), 3) << " mm RMS, " << Fixed(e["max_mm"].get<double>(), 3)
      << " mm max, " << e["left_out"].get<int>() << " left out\n";
  if (e.contains("flag")) out << "      FLAGGED: " << e["flag"].get<std::string>() << "\n";
}

int Map(const Options& o, std::ostream& out, std::ostream& err) {
  const auto [model, record] = ModelAndHandEye(o);
  const calib::RobotViews v = calib::LoadRobotViews(o.views);
  const auto found = Find(v, err);
  fs::create_directories(o.out);
  json images = json::array();
  std::vector<Vec3> all;
  std::vector<std::vector<Vec3>> clouds;  // per entry of `images` (empty: refused)
  for (size_t i = 0; i < found.size(); ++i) {
    json e = {{"name", found[i].name}};
    clouds.emplace_back();
    if (!found[i].HasLaser()) {
      e["refused"] = found[i].refused.empty() ? "no laser line" : found[i].refused;
      images.push_back(e);
      continue;
    }
    const Pose3& flange = v.images[i].base_from_flange;
    std::vector<float> quality;
    double depth_mm = 0.0;
    const auto cloud =
        CloudInBase(found[i], model, flange * record.flange_from_probe, &quality, &depth_mm);
    std::vector<double> xyz;
    for (const Vec3& p : cloud) xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
    const std::string file =
        (fs::path(o.out) / (fs::path(found[i].name).stem().string() + ".ply")).string();
    probe_fw::CloudFileMeta meta{model.serial, record.calibration_id, found[i].name, flange,
                                 "base",       std::nullopt};
    probe_fw::WriteCloudPly(file, xyz, quality, meta);
    e["cloud"] = file, e["points"] = cloud.size(), e["depth_mm"] = depth_mm;
    const double candidates = double(found[i].stripe_px.size() + found[i].stripe_saturated);
    e["saturated_share"] = found[i].stripe_saturated / candidates;
    images.push_back(e);
    clouds.back() = cloud;
    all.insert(all.end(), cloud.begin(), cloud.end());
  }
  if (all.empty()) throw UsageError("no image of " + o.views + " shows the laser line");
  const calib::Spread s = calib::SpreadAboutCommonPlane(all);
  const int flagged = JudgeImages(s, clouds, &images);
  json j = {{"probe_serial", model.serial},
            {"probe_calibration_id", model.calibration_id},
            {"hand_eye_calibration_id", record.calibration_id},
            {"images", images},
            {"points_about_common_plane", SpreadJson(s)}};
  if (o.json) {
    out << j.dump(2) << "\n";
    return flagged > 0 ? int{kExitFlagged} : int{kExitOk};
  }
  out << "laser points of " << found.size() << " images in the robot's base frame ("
      << model.calibration_id << ", hand-eye " << record.calibration_id << ")\n"
      << "  about one common plane: " << SpreadText(s) << "\n";
  for (const auto& e : images) PrintMapImage(e, out);
  out << "  clouds (PLY, base frame, quality: the firmware's stripe quality) written to " << o.out
      << "\n";
  return flagged > 0 ? int{kExitFlagged} : int{kExitOk};
}

// An image disagrees with the calibration when its corners through it sit beyond this many
// times the fit's own corner RMS, or its laser's mean height above the calibrated board beyond
// this many times the fit's heights' RMS (a bias: a saturated close-up, a moved light plane;
// the heights' scatter about it is each image's own: 0.12-0.54 mm RMS on the 24 Blaser images
// the calibration was fitted to).
constexpr double kDisagreeTimes = 3.0;

json BoardCheckJson(const calib::BoardImageCheck& c, const calib::CalibrationRecord& r) {
  json e = {{"seen_corner_rms_px", c.seen_corner_rms_px},
            {"expected_corner_rms_px", c.expected_corner_rms_px},
            {"board_offset_mm", c.board_offset_mm},
            {"board_turn_deg", c.board_turn_deg},
            {"laser_points", c.laser_points},
            {"laser_left_out", c.laser_left_out},
            {"laser_left_out_beyond_mm", c.laser_left_out_beyond_mm},
            {"laser_left_out_rule", "beyond 2.5 robust sigma (and 0.1 mm) of the seen board"}};
  if (c.laser_points > 0) {
    e["laser_above_seen_board"] = {
        {"rms_mm", c.laser_seen_rms_mm},
        {"max_mm", c.laser_seen_max_mm},
        {"all_points", {{"rms_mm", c.laser_all_rms_mm}, {"max_mm", c.laser_all_max_mm}}}};
    e["laser_above_calibrated_board"] = {{"mean_mm", c.laser_expected_mean_mm},
                                         {"rms_mm", c.laser_expected_rms_mm},
                                         {"max_mm", c.laser_expected_max_mm}};
  }
  std::string why;
  if (c.expected_corner_rms_px > kDisagreeTimes * r.corner_rms_px)
    why = "its corners sit " + Fixed(c.expected_corner_rms_px, 2) +
          " px RMS off where the calibration puts them (the fit's: " + Fixed(r.corner_rms_px, 2) +
          " px)";
  if (c.laser_points > 0 && std::abs(c.laser_expected_mean_mm) > kDisagreeTimes * r.point_rms_mm)
    why +=
        (why.empty() ? "" : ", ") + std::string("its laser ") + Fixed(c.laser_expected_mean_mm, 3) +
        " mm off the calibrated board on average (the fit's heights: " + Fixed(r.point_rms_mm, 3) +
        " mm RMS)";
  if (!why.empty())
    e["flag"] = why + ": the board sits " + Fixed(c.board_offset_mm, 2) + " mm, " +
                Fixed(c.board_turn_deg, 3) +
                " deg from where the calibration puts it (the robot's pose, a moved board or a "
                "stale hand-eye)";
  return e;
}

int BoardPose(const Options& o, std::ostream& out, std::ostream& err) {
  const auto [model, record] = ModelAndHandEye(o);
  const calib::RobotViews v = calib::LoadRobotViews(o.views);
  const auto found = Find(v, err);
  Vec3 n;
  double d = 0.0;
  model.projector.PlaneOf(0.0, &n, &d);
  json images = json::array();
  int flagged = 0;
  for (size_t i = 0; i < found.size(); ++i) {
    json e = {{"name", found[i].name}};
    if (!found[i].HasBoard()) {
      e["refused"] = "no board found in the image";
    } else {
      e.update(BoardCheckJson(
          calib::CheckBoardImage(found[i], v.images[i].base_from_flange,
                                 calib::IntrinsicsOf(model.camera), {n * d, n},
                                 record.flange_from_probe, record.base_from_board, v.board),
          record));
      flagged += e.contains("flag");
    }
    images.push_back(e);
  }
  const json j = {{"probe_calibration_id", model.calibration_id},
                  {"hand_eye_calibration_id", record.calibration_id},
                  {"images", images}};
  if (o.json) {
    out << j.dump(2) << "\n";
    return flagged > 0 ? int{kExitFlagged} : int{kExitOk};
  }
  out << "board poses with the calibration held fixed (" << model.calibration_id << ", hand-eye "
      << record.calibration_id << ")\n";
  for (const auto& e : images) {
    out << "    " << e["name"].get<std::string>() << ": ";
    if (e.contains("refused")) {
      out << e["refused"].get<std::string>() << "\n";
      continue;
    }
    out << "corners " << Fixed(e["seen_corner_rms_px"].get<double>(), 2) << " px RMS as seen, "
        << Fixed(e["expected_corner_rms_px"].get<double>(), 2)
        << " px through the calibration; the board " << Fixed(e["board_offset_mm"].get<double>(), 3)
        << " mm, " << Fixed(e["board_turn_deg"].get<double>(), 3) << " deg from where it is put";
    if (e.contains("laser_above_seen_board"))
      out << "; laser above the seen board "
          << Fixed(e["laser_above_seen_board"]["rms_mm"].get<double>(), 3)
          << " mm RMS, above the calibrated board "
          << Fixed(e["laser_above_calibrated_board"]["mean_mm"].get<double>(), 3) << " mm mean, "
          << Fixed(e["laser_above_calibrated_board"]["rms_mm"].get<double>(), 3) << " mm RMS ("
          << e["laser_points"].get<int>() << " points; " << e["laser_left_out"].get<int>()
          << " left out beyond " << Fixed(e["laser_left_out_beyond_mm"].get<double>(), 3)
          << " mm of the seen board; all points "
          << Fixed(e["laser_above_seen_board"]["all_points"]["rms_mm"].get<double>(), 3)
          << " mm RMS, "
          << Fixed(e["laser_above_seen_board"]["all_points"]["max_mm"].get<double>(), 2)
          << " mm max)";
    out << "\n";
    if (e.contains("flag")) out << "      FLAGGED: " << e["flag"].get<std::string>() << "\n";
  }
  return flagged > 0 ? int{kExitFlagged} : int{kExitOk};
}

}  // namespace

int RunRobotViewsCommand(const std::vector<std::string>& args,
                         std::ostream& out,
                         std::ostream& err) {
  const Options o = Parse(args);
  if (o.command == "line-laser") return LineLaser(o, out, err);
  if (o.command == "board-hand-eye") return BoardHandEye(o, out, err);
  if (o.command == "board-pose") return BoardPose(o, out, err);
  return Map(o, out, err);
}

}  // namespace mlp::host
