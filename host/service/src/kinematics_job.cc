// {"op": "kinematics"} (issue 54): the trunnion check from sphere captures the macro took at a
// plan of A and C positions in the machine frame (M101 with "pose_frame": "machine" on a
// xyzac-trt-kins machine: each capture's pose carries its joints and the kinematics' pins).

#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/trunnion_hal.h"
#include "mlp/calib/trunnion_report.h"
#include "mlp/geometry/datum.h"
#include "mlp/jobs/kinematics.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

// The pins' names as HAL has them, the pose's "pins" object's keys.
calib::TrtPins PinsOf(const json& pose, const std::string& where) {
  const json& p = jf::Object<JobInputError>(pose, "pins", where);
  calib::TrtPins pins;
  pins.x_rot_point = jf::Number<JobInputError>(p, "x-rot-point", where + ".pins");
  pins.y_rot_point = jf::Number<JobInputError>(p, "y-rot-point", where + ".pins");
  pins.z_rot_point = jf::Number<JobInputError>(p, "z-rot-point", where + ".pins");
  pins.y_offset = jf::Number<JobInputError>(p, "y-offset", where + ".pins");
  pins.z_offset = jf::Number<JobInputError>(p, "z-offset", where + ".pins");
  pins.tool_offset = jf::NumberOr<JobInputError>(p, "tool-offset", 0.0, where + ".pins");
  return pins;
}

// Two readings of the pins agree to the controller's readout: halcmd prints a pin to 7
// significant digits (0.1 um at 100-999 mm), the HAL file holds it to 0.1 nm.
bool SamePins(const calib::TrtPins& a, const calib::TrtPins& b) {
  const auto same = [](double x, double y) {
    return std::abs(x - y) <= 1e-6 * std::max({1.0, std::abs(x), std::abs(y)});
  };
  return same(a.x_rot_point, b.x_rot_point) && same(a.y_rot_point, b.y_rot_point) &&
         same(a.z_rot_point, b.z_rot_point) && same(a.y_offset, b.y_offset) &&
         same(a.z_offset, b.z_offset) && same(a.tool_offset, b.tool_offset);
}

jobs::KinematicsInputs ParseRequest(const json& r) {
  jobs::KinematicsInputs in;
  in.sphere_radius_mm = jf::Number<JobInputError>(r, "sphere_radius_mm", "request");
  if (!(in.sphere_radius_mm > 0)) throw JobInputError("request.sphere_radius_mm must be > 0");
  in.limits.pivot_mm = jf::NumberOr<JobInputError>(r, "limit_um", 10.0, "request") * 1e-3;
  in.limits.square_deg = jf::NumberOr<JobInputError>(r, "square_limit_deg", 0.01, "request");
  if (!(in.limits.pivot_mm > 0) || !(in.limits.square_deg > 0))
    throw JobInputError("request.limit_um and request.square_limit_deg must be > 0");
  if (!r.contains("captures")) throw JobInputError("request.captures must list the captures");
  in.calibrate = jf::FlagOr<JobInputError>(r, "calibrate", false, "request");
  in.null_band_mm = jf::NumberOr<JobInputError>(r, "null_band_um", 2.0, "request") * 1e-3;
  if (!(in.null_band_mm >= 0)) throw JobInputError("request.null_band_um must be >= 0");
  return in;
}

// The captures in the machine frame with their rotary joints; the pins every one was taken with
// (one set: pins changed during the plan would mix two models).
void Gather(const JobRun& run, const json& r, jobs::KinematicsInputs* in) {
  const geometry::Pose3 m = run.Calibration().flange_from_probe;
  std::optional<calib::TrtPins> pins;
  for (StoredCapture& s : LoadStoredCaptures(run.ctx, r.at("captures"), run.job)) {
    const std::string where = "capture " + s.id;
    if (s.pose.value("frame", "") != "machine" || !s.pose.contains("joints"))
      throw JobInputError(where +
                          " was not taken in the machine frame on a trunnion: take the sphere "
                          "plan with M101 jobs whose \"pose_frame\" is \"machine\"");
    const json& joints = jf::Object<JobInputError>(s.pose, "joints", where);
    const calib::TrtPins p = PinsOf(s.pose, where);
    if (pins && !SamePins(*pins, p))
      throw JobInputError(where +
                          " was taken with other kinematics pins than the first capture: "
                          "the pins changed during the plan; take it again");
    pins = p;
    in->captures.push_back({s.id, jf::Number<JobInputError>(joints, "a_deg", where),
                            jf::Number<JobInputError>(joints, "c_deg", where),
                            geometry::TransformPoints(s.mcs_from_flange * m, s.points_in_probe)});
  }
  if (!pins) throw JobInputError("request.captures is empty");
  in->pins = *pins;
}

json SpheresJson(const std::vector<jobs::SphereSeen>& spheres) {
  json out = json::array();
  for (const jobs::SphereSeen& s : spheres)
    out.push_back({{"capture", s.id},
                   {"a_deg", s.a_deg},
                   {"c_deg", s.c_deg},
                   {"centre_mm", JsonVec(s.centre_machine_mm)},
                   {"free_radius_mm", s.free_radius_mm},
                   {"rms_mm", s.rms_mm},
                   {"points", s.points},
                   {"left_out", s.left_out}});
  return out;
}

std::string WriteReport(JobContext& ctx,
                        std::int64_t job,
                        const jobs::KinematicsInputs& in,
                        const jobs::KinematicsOutcome& o,
                        const std::vector<calib::TrunnionObservation>& centres) {
  const std::filesystem::path dir(ctx.config.ReportDir());
  std::filesystem::create_directories(dir);
  std::string path = (dir / (ctx.machine.name + "-job" + std::to_string(job) + ".svg")).string();
  base::WriteFileAtomically(path, calib::TrunnionSvg(centres, *o.fit, in.pins, in.limits.pivot_mm));
  return path;
}

json PinsJson(const calib::TrtPins& p) {
  return {{"x-rot-point", p.x_rot_point},
          {"y-rot-point", p.y_rot_point},
          {"y-offset", p.y_offset},
          {"z-offset", p.z_offset}};
}

// The calibration written to the HAL file that sets the pins at start (atomically, announced
// in the history first, before/after logged), after checking that the file holds what the
// running machine held at the captures: a file and a machine that disagree would make the
// next start load something nobody measured. The live pins are M101's to set (HAL is the
// controller's), from the reply's "pins_written".
json WritePins(JobContext& ctx,
               std::int64_t job,
               const jobs::KinematicsInputs& in,
               const calib::TrtPins& next,
               const json& reply) {
  const std::string& path = ctx.machine.controller.kinematics_hal;
  if (path.empty())
    throw JobInputError("machine " + ctx.machine.name +
                        " has no controller.kinematics_hal: a kinematics calibration has no "
                        "file to write (docs/HOSTD.md)");
  const std::string text = base::ReadFileAs<JobInputError>(path, "kinematics_hal: ");
  calib::TrtPins in_file;
  try {
    in_file = calib::ParseTrtPinsHal(text);
  } catch (const calib::TrunnionError& e) {
    throw JobInputError(path + ": " + e.what());
  }
  if (!SamePins(in_file, in.pins))
    throw JobInputError(path + " holds other pins than the machine ran the captures with (" +
                        PinsJson(in_file).dump() + " against " + PinsJson(in.pins).dump() +
                        "): nothing written; restart the machine or check the file");
  history::OffsetWriteRow row;
  row.adapter = ctx.machine.name + ":" + path;
  row.target = "xyzac-trt-kins pins";
  row.before = PinsJson(in.pins), row.after = PinsJson(next);
  row.state = "intent";
  ctx.history.AddWriteIntents(job, {row}, reply);
  base::WriteFileAtomically(path, calib::RewriteTrtPinsHal(text, next));
  ctx.history.MarkWritesDone(job);
  ctx.log("job " + std::to_string(job) + ": " + path + " pins " + row.before.dump() + " -> " +
          row.after.dump());
  return {{"file", path}, {"before", row.before}, {"after", row.after}};
}

json LineJson(const calib::AxisLine& l) {
  return {{"point_mm", JsonVec(l.point)}, {"direction", JsonVec(l.direction)}};
}

calib::AxisLine LineFrom(const json& j, const char* key, const std::string& where) {
  const json& o = jf::Object<JobInputError>(j, key, where);
  return {jf::Vector3<JobInputError>(o, "point_mm", where + "." + key),
          jf::Vector3<JobInputError>(o, "direction", where + "." + key).normalized()};
}

// What a fit says of the machine itself, whatever the pins: the four sums and the angles, as
// the drift between two checks compares them.
json StateJson(const calib::TrunnionFit& fit) {
  return {{"pivots_mm",
           {{"c_x", fit.c_x_mm}, {"c_y", fit.c_y_mm}, {"a_y", fit.a_y_mm}, {"a_z", fit.a_z_mm}}},
          {"angles_deg",
           {{"a_about_z", fit.a_about_z_deg},
            {"a_about_y", fit.a_about_y_deg},
            {"c_about_x", fit.c_about_x_deg},
            {"c_about_y", fit.c_about_y_deg}}}};
}

std::string KeptPath(const JobContext& ctx) {
  return ctx.config.KinematicsDir() + "/" + ctx.machine.name + ".json";
}

// The machine's change since the fit kept before this one (a warm-up study: the same check run
// twice): each sum and angle's difference, the hours between; null for a first check.
json DriftSinceKept(const JobContext& ctx, const calib::TrunnionFit& fit) {
  if (!std::filesystem::exists(KeptPath(ctx))) return nullptr;
  const json kept =
      json::parse(base::ReadFileAs<JobInputError>(KeptPath(ctx), "kinematics: "), nullptr, false);
  if (kept.is_discarded() || !kept.contains("state")) return nullptr;  // an older file
  const json now = StateJson(fit);
  json drift = {{"since_job", kept.value("job", 0)},
                {"hours", AgeHours(kept.value("time_utc", ""))}};
  for (const char* group : {"pivots_mm", "angles_deg"})
    for (const auto& [name, value] : now.at(group).items())
      drift[group][name] = value.get<double>() - kept.at("state").at(group).value(name, 0.0);
  return drift;
}

// The fitted axes kept for the jobs that map captures through them (UseFittedKinematics) and
// for the next check's drift: kinematics/<machine>.json, replaced whole by each fit.
void KeepFit(const JobContext& ctx, std::int64_t job, const calib::TrunnionFit& fit) {
  std::filesystem::create_directories(ctx.config.KinematicsDir());
  const json kept = {{"format", "mlprobe-trunnion-fit/1"},    {"job", job},
                     {"time_utc", base::UtcTimestamp()},      {"a_axis", LineJson(fit.axes.a)},
                     {"c_axis", LineJson(fit.axes.c)},        {"state", StateJson(fit)},
                     {"residual_rms_mm", fit.residual_rms_mm}};
  base::WriteFileAtomically(KeptPath(ctx), kept.dump(1) + "\n");
}

}  // namespace

json RunKinematicsJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "kinematics", r);
  try {
    jobs::KinematicsInputs in = ParseRequest(r);
    Gather(run, r, &in);
    const jobs::KinematicsOutcome o = jobs::AssessKinematics(in);
    run.reply["spheres"] = SpheresJson(o.spheres);
    if (!o.fit) return run.Refuse(o.problems);
    std::vector<calib::TrunnionObservation> centres;
    for (const jobs::SphereSeen& s : o.spheres)
      centres.push_back({s.a_deg, s.c_deg, s.centre_machine_mm});
    run.reply.update(json(calib::TrunnionReportJson(centres, *o.fit, in.pins, in.limits)));
    run.reply["report"] = WriteReport(ctx, run.job, in, o, centres);
    run.reply["drift"] = DriftSinceKept(ctx, *o.fit);
    KeepFit(ctx, run.job, *o.fit);
    if (in.calibrate) run.reply["changes"] = calib::PinChangesJson(o.changes);
    ctx.history.AddResult(run.job, {"trunnion", run.reply, json::object()});
    if (!in.calibrate)
      return run.Finish(
          o.within ? history::JobStatus::kInTolerance : history::JobStatus::kOutOfTolerance, true);
    if (!o.new_pins) return run.Refuse(o.problems);
    const bool any = std::any_of(o.changes.begin(), o.changes.end(),
                                 [](const jobs::PinChange& c) { return c.changed; });
    run.reply["pins_written"] = any ? WritePins(ctx, run.job, in, *o.new_pins, run.reply) : json();
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

void UseFittedKinematics(const JobContext& ctx, std::vector<StoredCapture>* captures) {
  const std::string path = KeptPath(ctx);
  if (!std::filesystem::exists(path))
    throw JobInputError("machine " + ctx.machine.name +
                        " has no fitted kinematics: run a kinematics job (the sphere plan) first");
  const json kept =
      json::parse(base::ReadFileAs<JobInputError>(path, "kinematics: "), nullptr, false);
  if (kept.is_discarded() || kept.value("format", "") != "mlprobe-trunnion-fit/1")
    throw JobInputError(path + " is not a mlprobe-trunnion-fit/1 file");
  const calib::TrunnionAxes axes{LineFrom(kept, "a_axis", path), LineFrom(kept, "c_axis", path)};
  for (StoredCapture& s : *captures) {
    if (s.pose.value("frame", "table") == "machine") continue;  // H needs no axes there
    const std::string where = "capture " + s.id;
    if (!s.pose.contains("joints"))
      throw JobInputError(where + " carries no joints: the fitted kinematics cannot place it");
    const json& j = jf::Object<JobInputError>(s.pose, "joints", where);
    const auto n = [&](const char* key) { return jf::Number<JobInputError>(j, key, where); };
    s.mcs_from_flange =
        calib::TableFromFlange(axes, geometry::Vec3(n("x_mm"), n("y_mm"), n("z_mm")), n("a_deg"),
                               n("c_deg"), n("spindle_deg"));
  }
}

}  // namespace mlp::service
