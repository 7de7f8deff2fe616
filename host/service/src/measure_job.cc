#include "mlp/base/check.h"
#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/features/decision.h"
#include "mlp/features/feature.h"
#include "mlp/jobs/measure.h"
#include "mlp/nc/tool_table.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <array>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <sstream>

#include "feature_request_json.h"
#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;
using geometry::Vec3;

nc::ToolRegister RegisterOf(const std::string& s) {
  if (s == "length_geometry") return nc::ToolRegister::kLengthGeometry;
  if (s == "length_wear") return nc::ToolRegister::kLengthWear;
  if (s == "radius_geometry") return nc::ToolRegister::kRadiusGeometry;
  if (s == "radius_wear") return nc::ToolRegister::kRadiusWear;
  throw JobInputError(
      "update.register must be length_geometry, length_wear, radius_geometry "
      "or radius_wear, not \"" +
      s + "\"");
}

using jobs::MeasureRequest;
using jobs::ToolUpdateRequest;
using jobs::WorkUpdateRequest;

ToolUpdateRequest ParseToolUpdate(const json& u) {
  const std::string w = "request.update";
  ToolUpdateRequest t;
  t.offset = jf::Integer<JobInputError>(u, "offset", w);
  t.reg = RegisterOf(jf::Text<JobInputError>(u, "register", w));
  features::Feedback& f = t.feedback;
  f.offset_number = t.offset;
  f.reg = t.reg;
  f.percent = jf::NumberOr<JobInputError>(u, "percent", f.percent, w);
  f.null_band_mm = jf::NumberOr<JobInputError>(u, "null_band_mm", f.null_band_mm, w);
  f.upper_limit_mm = jf::NumberOr<JobInputError>(u, "upper_limit_mm", f.upper_limit_mm, w);
  f.experience_mm = jf::NumberOr<JobInputError>(u, "experience_mm", f.experience_mm, w);
  return t;
}

// "update_work": {"offset": n, "axes": "xy"}: the work offset moved by where the feature was
// found against its nominal (a part set up on one feature), in the control (incremental).
WorkUpdateRequest ParseWorkUpdate(const json& u) {
  WorkUpdateRequest w;
  w.offset = jf::Integer<JobInputError>(u, "offset", "request.update_work");
  const std::string axes = jf::Text<JobInputError>(u, "axes", "request.update_work");
  if (axes.empty() || axes.find_first_not_of("xyz") != std::string::npos)
    throw JobInputError("request.update_work.axes: one or more of x, y, z (\"xy\")");
  for (size_t a = 0; a < 3; ++a) w.axes[a] = axes.find("xyz"[a]) != std::string::npos;
  return w;
}

MeasureRequest ParseMeasureRequest(const json& r, const std::string& data_dir) {
  MeasureRequest m;
  m.feature = ParseFeatureRequest(r, data_dir);
  if (!r.contains("captures"))
    throw JobInputError("request.captures must list the capture jobs to use");
  if (r.contains("update"))
    m.update = ParseToolUpdate(jf::Object<JobInputError>(r, "update", "request"));
  if (r.contains("update_work"))
    m.update_work = ParseWorkUpdate(jf::Object<JobInputError>(r, "update_work", "request"));
  m.report = jf::FlagOr<JobInputError>(r, "report", true, "request");
  jobs::CheckUpdatesFit(m);
  return m;
}

// The report's picture: data_dir/reports/<machine>-job<N>.svg.
std::string WriteReport(JobContext& ctx,
                        std::int64_t job,
                        const jobs::MeasureOutcome& o,
                        const std::string& time_utc) {
  const std::string title =
      "job " + std::to_string(job) + " - " + o.measured.feature + " - " + ctx.machine.name;
  const std::filesystem::path dir(ctx.config.ReportDir());
  std::filesystem::create_directories(dir);
  std::string path = (dir / (ctx.machine.name + "-job" + std::to_string(job) + ".svg")).string();
  base::WriteFileAtomically(path, jobs::MeasureReportSvg(o, title, time_utc));
  return path;
}

jobs::CalibrationFacts FactsOf(const calib::CalibrationRecord& cal) {
  return {cal.calibration_id, cal.probe_serial, AgeHours(cal.created_utc)};
}

json ResultFields(const jobs::MeasureOutcome& o, const calib::CalibrationRecord& cal) {
  const jobs::Measured& ms = o.measured;
  json fields = ReadingsJson(ms.readings);
  fields.update({{"feature", ms.feature},
                 {"calibration_id", cal.calibration_id},
                 {"size_" + ms.traits.unit, ms.size},
                 {"error_" + ms.traits.unit, o.decision.error_mm},
                 {"verdict", o.verdict},
                 {"reason", o.reason},
                 {"offset_change_mm", o.decision.offset_change_mm},
                 {"time_utc", base::UtcTimestamp()}});
  return fields;
}

// The decision's tool change as the controller takes it (ResolveToolChange reads LinuxCNC's
// table), said in the reply; nullopt when the decision changes no offset.
std::optional<nc::ToolOffsetChange> ToolChangeFor(const MachineConfig& m,
                                                  const jobs::MeasureOutcome& o,
                                                  json* reply) {
  if (!o.decision.update) return std::nullopt;
  std::string note;
  const nc::ToolOffsetChange t = ResolveToolChange(
      m.controller, o.feedback.offset_number, o.feedback.reg, o.decision.offset_change_mm, &note);
  (*reply)["update"] = {{"offset", t.tool},
                        {"register", nc::ToString(t.reg)},
                        {"before_mm", t.incremental ? json() : json(t.before_mm)},
                        {"after_mm", t.incremental ? json() : json(t.after_mm)},
                        {"change_mm", o.decision.offset_change_mm}};
  if (!note.empty()) (*reply)["update"]["note"] = note;
  return t;
}

}  // namespace

// The pipeline: request -> evidence -> measure, decide, gate (mlp::jobs) -> record -> write ->
// record.
json RunMeasureJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "measure", r);
  json& reply = run.reply;
  try {
    const MeasureRequest request = ParseMeasureRequest(r, ctx.config.data_dir);
    const calib::CalibrationRecord& cal = run.Calibration();
    const Evidence ev =
        LoadCaptures(ctx, r.at("captures"), cal.flange_from_probe, run.job, FittedKinematics(r));
    const jobs::MeasureOutcome o =
        jobs::AssessMeasure(request, ev, FactsOf(cal), ctx.machine.limits);
    const jobs::Measured& ms = o.measured;
    reply.update(ResultFields(o, cal));
    ctx.history.AddResult(run.job, {ms.feature,
                                    reply,
                                    {{"verdict", o.verdict},
                                     {"error_" + ms.traits.unit, o.decision.error_mm},
                                     {"offset_change_mm", o.decision.offset_change_mm},
                                     {"reason", o.reason}}});
    if (!o.refusal.empty()) return run.Refuse(o.refusal);
    const nc::NcResult out = jobs::MeasureChanges(
        o, run.job, ctx.machine.controller.kind == ControllerConfig::Kind::kLinuxCnc,
        ToolChangeFor(ctx.machine, o, &reply));
    if (!out.work.empty())
      reply["update_work"] = {
          {"offset", out.work[0].index},
          {"shift_mm",
           {out.work[0].after_mm[0], out.work[0].after_mm[1], out.work[0].after_mm[2]}}};
    if (request.report) reply["report"] = WriteReport(ctx, run.job, o, reply.value("time_utc", ""));
    if (o.decision.verdict == features::Verdict::kUpperLimitExceeded)
      reply["alarm"] = o.decision.reason;
    reply["status"] = o.in_tolerance ? "in_tolerance" : "out_of_tolerance";  // if a stop comes
    reply["files"] = WriteToController(ctx, run.job, out, reply, OffsetWriteRows(out));
    return run.Finish(
        o.in_tolerance ? history::JobStatus::kInTolerance : history::JobStatus::kOutOfTolerance,
        true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
