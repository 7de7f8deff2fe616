#include "mlp/host/calibrate_command.h"

#include "mlp/base/input_error.h"
#include "mlp/base/units.h"
#include "mlp/calib/camera_calib.h"
#include "mlp/calib/capture_io.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/calib/hand_eye_json.h"
#include "mlp/calib/recheck.h"
#include "mlp/calib/record.h"
#include "mlp/host/cli.h"
#include "mlp/host/cloud_io.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/probe_model.h"

#include <filesystem>
#include <iomanip>
#include <map>
#include <ostream>
#include <sstream>

#include "calibrate_optics.h"
#include "calibrate_robot.h"
#include "format_numbers.h"

namespace mlp::host {
namespace {

namespace fs = std::filesystem;
using calib::Pose3;
using calib::Vec3;
using json = nlohmann::ordered_json;

constexpr const char* kUsage =
    "usage: mlp calibrate camera    --views MANIFEST [--out CAMERA.json] [--json]\n"
    "       mlp calibrate projector --views MANIFEST --design PROBE_FILE --out PROBE_FILE\n"
    "                               [--id CALIBRATION_ID] [--json]\n"
    "       mlp calibrate line-laser --views ROBOT_VIEWS --design PROBE_FILE --out PROBE_FILE\n"
    "                                [--id CALIBRATION_ID] [--json]\n"
    "       mlp calibrate board-hand-eye --views ROBOT_VIEWS --probe PROBE_FILE --store DIR\n"
    "                                [--refined-probe PROBE_FILE] [--max-std-mm 0.2]\n"
    "                                [--lever-mm 100] [--dry-run] [--json]\n"
    "       mlp calibrate map --views ROBOT_VIEWS --probe PROBE_FILE --store DIR --out DIR\n"
    "                         [--calibration ID] [--json]\n"
    "       mlp calibrate board-pose --views ROBOT_VIEWS --probe PROBE_FILE --store DIR\n"
    "                         [--calibration ID] [--json]\n"
    "       mlp calibrate hand-eye --captures MANIFEST --store DIR [--dry-run] [--json]\n"
    "                              [--estimate scale_x,scale_y,scale_z,incidence_bias]\n"
    "       mlp calibrate recheck  --captures MANIFEST --store DIR [--sphere-moved] [--json]\n"
    "       mlp calibrate list     --store DIR --probe SERIAL [--json]\n"
    "  camera    camera intrinsics and distortion from LED frames of a chessboard\n"
    "  projector camera and MEMS projector adjusted together from the same views' LED frames\n"
    "            and stripe files (mlp-fw stripes); writes the probe model file the firmware\n"
    "            reads (a new file: an existing one is never overwritten)\n"
    "  line-laser  a camera with a fixed line laser: camera and light plane from images of a\n"
    "            chessboard with the line on it; writes the probe model file (one light plane)\n"
    "  board-hand-eye  hand-eye from a fixed chessboard and the robot's poses (AX = XB, then\n"
    "            corners and laser points together); stored as a new calibration. With\n"
    "            --refined-probe the light plane is refined too and a new probe model written\n"
    "  map       every image's laser points (the firmware's triangulation) in the robot's base\n"
    "            frame, one PLY per image; their spread about one common plane (a check on\n"
    "            images the calibration was not fitted to)\n"
    "  board-pose  each image's board pose with the calibration held fixed, against where the\n"
    "            calibration puts the board, and the laser's heights above both (a check a\n"
    "            user runs on a new image; exit 5 when an image disagrees)\n"
    "  --views ROBOT_VIEWS  JSON \"mlprobe-robot-views/1\": images, board, channels, pose file\n"
    "  hand-eye  sphere hand-eye: M (probe -> flange) and the sphere centre from clouds of the\n"
    "            reference sphere at known flange poses; stored as a new calibration\n"
    "  recheck   quick re-calibration after a disturbance, from the probe's latest full\n"
    "            calibration (never from an earlier recheck); stored as a new record\n"
    "  list      the calibrations of a probe, oldest first\n"
    "  --views MANIFEST     JSON \"mlprobe-board-views/1\": the board and the capture folders\n"
    "  --estimate LIST      hand-eye: estimate the sensor's own scale per probe axis and its\n"
    "            depth bias with the angle of incidence too, and report them (a diagnosis:\n"
    "            nothing is stored, since the firmware does not correct its readings so)\n"
    "  --captures MANIFEST  JSON \"mlprobe-sphere-captures/1\": probe serial, sphere radius,\n"
    "            optional known centre coordinates, and per capture a cloud file\n"
    "            (.xyz/.txt/.pcd/.ply, or an OpenCV .yml profile) with its flange pose\n"
    "  (formats: docs/CALIBRATION.md)\n"
    "exit codes: 0 done, 2 bad arguments or input, 3 the captures do not determine the\n"
    "            calibration (what would fix it is printed), 4 recheck: a full calibration is\n"
    "            required, 5 map: an image is flagged (saturated, or off the others: the\n"
    "            reason is printed), 1 bug; nothing is stored unless the exit code is 0\n";

struct Command {
  std::string command, captures, store, probe;
  bool json = false, dry_run = false, sphere_moved = false;
  calib::SensorModelOptions estimate;
};

// "scale_x,scale_z,incidence_bias" -> which sensor parameters the hand-eye estimates.
calib::SensorModelOptions ParseEstimate(const std::string& list) {
  calib::SensorModelOptions o;
  std::stringstream in(list);
  for (std::string name; std::getline(in, name, ',');) {
    if (name == "scale_x")
      o.scale_x = true;
    else if (name == "scale_y")
      o.scale_y = true;
    else if (name == "scale_z")
      o.scale_z = true;
    else if (name == "incidence_bias")
      o.incidence_bias = true;
    else
      throw UsageError("--estimate: unknown parameter '" + name +
                       "' (scale_x, scale_y, scale_z, incidence_bias)");
  }
  if (!o.Any()) throw UsageError("--estimate needs at least one parameter");
  return o;
}

Command ParseArgs(const std::vector<std::string>& args) {
  if (args.empty()) throw UsageError("a sub-command is needed");
  const base::Args f({args.begin() + 1, args.end()},
                     {{"--captures", "--store", "--probe", "--estimate"},
                      {"--json", "--dry-run", "--sphere-moved"}});
  Command a;
  a.command = args[0];
  a.captures = f.Text("--captures", "");
  a.store = f.Text("--store", "");
  a.probe = f.Text("--probe", "");
  a.json = f.Has("--json");
  a.dry_run = f.Has("--dry-run");
  a.sphere_moved = f.Has("--sphere-moved");
  if (f.Has("--estimate")) a.estimate = ParseEstimate(f.Text("--estimate"));
  if (a.store.empty()) throw UsageError("--store DIR is required");
  if (a.command != "list" && a.captures.empty())
    throw UsageError("--captures MANIFEST is required");
  if (a.command == "list" && a.probe.empty()) throw UsageError("--probe SERIAL is required");
  if (a.estimate.Any() && a.command != "hand-eye") throw UsageError("--estimate is for hand-eye");
  return a;
}

// The manifest is calib's format; the clouds it names other than line-scanner profiles are read
// by the host's cloud reader (.xyz, .pcd, .ply).
calib::SphereCaptureManifest LoadManifest(const std::string& path) {
  return calib::LoadSphereCaptureManifest(
      path, [](const std::string& cloud) { return ReadCloud(cloud).points; });
}

void PrintSensorAndValidation(const calib::HandEyeResult& r, std::ostream& out) {
  const calib::SensorEstimate& e = r.sensor;
  if (e.estimated) {
    out << "  sensor scale x " << Fixed(e.scale.x(), 5) << " +- " << Fixed(e.scale_std.x(), 5)
        << ", y " << Fixed(e.scale.y(), 5) << " +- " << Fixed(e.scale_std.y(), 5) << ", z "
        << Fixed(e.scale.z(), 5) << " +- " << Fixed(e.scale_std.z(), 5) << "; incidence bias "
        << Fixed(e.incidence_bias_mm * 1e3, 1) << " +- " << Fixed(e.incidence_bias_std_mm * 1e3, 1)
        << " um at grazing light\n";
    for (const auto& f : e.findings) out << "  finding: " << f << "\n";
  }
  if (!r.leave_one_out.captures.empty()) {
    out << "  leave-one-out: held-out point RMS " << Fixed(r.leave_one_out.rms_mm * 1e3, 2)
        << " um, held-out centre error RMS " << Fixed(r.leave_one_out.centre_error_rms_mm * 1e3, 2)
        << " um\n";
  }
}

int HandEye(const Command& a, std::ostream& out, std::ostream& err) {
  const calib::SphereCaptureManifest m = LoadManifest(a.captures);
  calib::HandEyeOptions o;
  o.sphere_radius_mm = m.sphere_radius_mm;
  o.known_centre_mcs = m.known_centre_mcs;
  if (m.max_std_mm) o.max_std_mm = *m.max_std_mm;
  if (m.lever_mm) o.lever_mm = *m.lever_mm;
  o.sensor = a.estimate;
  if (!a.json)
    err << "mlp calibrate: solving the hand-eye from " << m.captures.size() << " captures\n";
  const calib::HandEyeResult r = calib::SolveSphereHandEye(m.captures, o);
  // With a sensor model, M assumes readings corrected by it, which the firmware does not make:
  // a diagnosis, never a calibration to measure with.
  std::string id = a.estimate.Any() ? "(not stored: a diagnosis with the sensor model)"
                                    : "(not stored: --dry-run)";
  if (!a.dry_run && !a.estimate.Any()) {
    id = calib::CalibrationStore(a.store).Save(
        calib::MakeRecord(m.probe_serial, r, m.captures, m.sphere_radius_mm));
  }
  const Eigen::AngleAxisd aa(r.flange_from_probe.linear());
  if (a.json) {
    json j = {{"calibration_id", id}, {"probe_serial", m.probe_serial}};
    j.update(calib::HandEyeResultJson(r));
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  out << "hand-eye calibration " << id << " of probe " << m.probe_serial << "\n"
      << "  M translation " << Vec(r.flange_from_probe.translation(), 4) << " mm  (1 sigma "
      << Vec(Vec3(std::sqrt(r.covariance(3, 3)), std::sqrt(r.covariance(4, 4)),
                  std::sqrt(r.covariance(5, 5))) *
                 1e3,
             2)
      << " um)\n"
      << "  M rotation " << Vec(aa.axis() * aa.angle(), 6) << " rad (rotation vector)\n"
      << "  sphere centre " << Vec(r.centre_mcs, 4) << " mm (MCS)\n"
      << "  point RMS " << Fixed(r.point_rms_mm * 1e3, 2) << " um over " << r.points_used
      << " points, " << r.points_rejected << " rejected; centre spread RMS "
      << Fixed(r.centre_spread_rms_mm * 1e3, 2) << " um about the captures' mean, which is "
      << Fixed(r.centre_mean_offset_mm * 1e3, 2) << " um from the centre\n";
  for (const auto& c : r.captures) {
    out << "    " << std::left << std::setw(16) << c.id << std::right << std::setw(7) << c.inliers
        << "/" << std::setw(7) << c.points << " points  RMS " << Fixed(c.rms_mm * 1e3, 2)
        << " um\n";
  }
  PrintSensorAndValidation(r, out);
  for (const auto& w : r.warnings) out << "  warning: " << w << "\n";
  return kExitOk;
}

int Recheck(const Command& a, std::ostream& out, std::ostream& err) {
  const calib::SphereCaptureManifest m = LoadManifest(a.captures);
  const calib::CalibrationStore store(a.store);
  const auto original = store.Latest(m.probe_serial, calib::RecordKind::kHandEye);
  if (!original)
    throw UsageError("probe " + m.probe_serial + " has no full calibration in " + a.store);
  if (original->reference != calib::Reference::kSphere)
    throw UsageError("the latest full calibration of probe " + m.probe_serial + " (" +
                     original->calibration_id + ") was measured against a board: a recheck " +
                     "needs a sphere calibration (mlp calibrate hand-eye)");
  calib::RecheckOptions o;
  o.sphere_radius_mm = m.sphere_radius_mm;
  o.original_flange_from_probe = original->flange_from_probe;
  o.original_centre_mcs = original->sphere_centre_mcs;
  o.sphere_moved = a.sphere_moved;
  std::vector<calib::RecheckCapture> captures;
  for (const auto& c : m.captures) captures.push_back({c.id, c.mcs_from_flange, c.points_in_probe});
  const calib::RecheckResult r = calib::Recheck(captures, o);
  std::string id;
  if (!r.full_calibration_required) id = store.Save(calib::MakeRecord(*original, r, captures));
  if (a.json) {
    json j = {{"calibration_id", id}, {"parent_id", original->calibration_id}};
    j.update(calib::RecheckResultJson(r));
    out << j.dump(2) << "\n";
  } else {
    out << "recheck of probe " << m.probe_serial << " against " << original->calibration_id << "\n"
        << "  offset " << Vec(r.offset_in_flange_mm * 1e3, 2) << " um (flange frame)\n"
        << "  rotation " << Vec(r.rotation_in_flange_rad * base::kArcsecPerRad, 2) << " arcsec\n";
    if (a.sphere_moved) out << "  sphere moved " << Vec(r.centre_shift_mm * 1e3, 2) << " um\n";
    out << "  centre residual after the correction " << Fixed(r.residual_after_rms_mm * 1e3, 2)
        << " um RMS; apparent radius change " << Fixed(r.apparent_radius_change_mm * 1e3, 2)
        << " um\n"
        << "  depth scale of the readings " << Fixed(r.depth_scale, 5) << " +- "
        << Fixed(r.depth_scale_std, 5) << "\n";
    for (const auto& s : r.not_determined) out << "  not determined: " << s << "\n";
    if (!id.empty()) out << "  stored as " << id << "\n";
  }
  if (r.full_calibration_required) {
    err << "mlp calibrate: full calibration required: " << r.reason << " (nothing stored)\n";
    return kExitFullCalibrationRequired;
  }
  return kExitOk;
}

int List(const Command& a, std::ostream& out) {
  const auto all = calib::CalibrationStore(a.store).List(a.probe);
  if (a.json) {
    json j = json::array();
    for (const auto& r : all) {
      j.push_back({{"calibration_id", r.calibration_id},
                   {"kind", r.kind == calib::RecordKind::kHandEye ? "hand-eye" : "recheck"},
                   {"created_utc", r.created_utc},
                   {"parent_id", r.parent_id},
                   {"point_rms_mm", r.point_rms_mm}});
    }
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  if (all.empty()) out << "no calibration of probe " << a.probe << " in " << a.store << "\n";
  for (const auto& r : all) {
    out << r.created_utc << "  "
        << (r.kind == calib::RecordKind::kHandEye ? "hand-eye" : "recheck ") << "  "
        << r.calibration_id << (r.parent_id.empty() ? "" : "  (corrects " + r.parent_id + ")")
        << "\n";
  }
  return kExitOk;
}

}  // namespace

int RunCalibrateCommand(const std::vector<std::string>& args,
                        std::ostream& out,
                        std::ostream& err) {
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    out << kUsage;
    return kExitOk;
  }
  try {
    if (!args.empty() && (args[0] == "camera" || args[0] == "projector"))
      return RunCameraProjectorCommand(args, out, err);
    if (!args.empty() && (args[0] == "line-laser" || args[0] == "board-hand-eye" ||
                          args[0] == "map" || args[0] == "board-pose"))
      return RunRobotViewsCommand(args, out, err);
    const Command a = ParseArgs(args);
    if (a.command == "hand-eye") return HandEye(a, out, err);
    if (a.command == "recheck") return Recheck(a, out, err);
    if (a.command == "list") return List(a, out);
    throw UsageError("unknown sub-command '" + a.command + "'");
  } catch (const UsageError& e) {
    err << "mlp calibrate: " << e.what() << "\n" << kUsage;
  } catch (const calib::HandEyeError& e) {
    err << "mlp calibrate: " << e.what() << "\n";
    for (const auto& p : e.proposals()) err << "  to fix it: " << p << "\n";
    if (e.kind() == calib::HandEyeError::Kind::kUnderDetermined) return kExitUnderDetermined;
    return kExitBadInput;
  } catch (const base::InputError& e) {  // captures, images, records, models: bad input
    err << "mlp calibrate: " << e.what() << "\n";
  } catch (const std::exception& e) {
    err << "mlp calibrate: internal error: " << e.what() << "\n";
    return kExitInternal;
  }
  return kExitBadInput;
}

}  // namespace mlp::host
