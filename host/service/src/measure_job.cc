#include "mlp/calib/record.h"
#include "mlp/jobs/decision.h"
#include "mlp/jobs/feature.h"
#include "mlp/jobs/report.h"
#include "mlp/nc/tool_table.h"
#include "mlp/probe_fw/json_fields.h"
#include "mlp/service/adapters.h"

#include <filesystem>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = probe_fw::json_fields;
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

jobs::BoreNominal ParseBore(const json& r) {
  return ParseBoreNominal(jf::Object<JobInputError>(r, "nominal", "request"), "request.nominal");
}

jobs::Feedback ParseUpdate(const json& r, double change_per_error) {
  jobs::Feedback f;
  f.change_per_error = change_per_error;
  if (!r.contains("update")) return f;  // report only
  const json& u = jf::Object<JobInputError>(r, "update", "request");
  const std::string w = "request.update";
  f.offset_number = jf::Integer<JobInputError>(u, "offset", w);
  f.reg = RegisterOf(jf::Text<JobInputError>(u, "register", w));
  f.percent = jf::NumberOr<JobInputError>(u, "percent", f.percent, w);
  f.null_band_mm = jf::NumberOr<JobInputError>(u, "null_band_mm", f.null_band_mm, w);
  f.upper_limit_mm = jf::NumberOr<JobInputError>(u, "upper_limit_mm", f.upper_limit_mm, w);
  f.experience_mm = jf::NumberOr<JobInputError>(u, "experience_mm", f.experience_mm, w);
  return f;
}

// The picture for the operator: data_dir/reports/<machine>-job<N>.svg.
std::string WriteReport(JobContext& ctx,
                        std::int64_t job,
                        const jobs::BoreMeasurement& bore,
                        const jobs::SizeSpec& spec,
                        double size,
                        const jobs::SizeDecision& d,
                        const json& reply) {
  jobs::BoreReport rep;
  rep.title = "job " + std::to_string(job) + " - bore - " + ctx.machine.name;
  rep.nominal_mm = spec.nominal_mm;
  rep.upper_tol_mm = spec.upper_tol_mm;
  rep.lower_tol_mm = spec.lower_tol_mm;
  rep.bore = bore;
  rep.size_mm = size;
  rep.error_mm = d.error_mm;
  rep.verdict = jobs::ToString(d.verdict);
  rep.decision = d.reason;
  rep.time_utc = reply.value("time_utc", "");
  const std::filesystem::path dir(ctx.config.ReportDir());
  std::filesystem::create_directories(dir);
  const std::string path =
      (dir / (ctx.machine.name + "-job" + std::to_string(job) + ".svg")).string();
  nc::WriteFileAtomically(path, jobs::BoreReportSvg(rep));
  return path;
}

}  // namespace

json RunMeasureJob(JobContext& ctx, const json& r) {
  const MachineConfig& m = ctx.machine;
  JobRun run(ctx, "measure", r);
  json& reply = run.reply;
  const std::int64_t job = run.job;
  try {
    const std::string feature = jf::Text<JobInputError>(r, "feature", "request");
    if (feature != "bore") throw JobInputError("feature \"" + feature + "\" is not measured yet");
    const calib::CalibrationRecord* cal = &run.Calibration();
    const jobs::BoreNominal nominal = ParseBore(r);
    if (!r.contains("captures"))
      throw JobInputError("request.captures must list the capture jobs to use");
    const Evidence ev = LoadCaptures(ctx, r.at("captures"), cal->flange_from_probe, job);
    const jobs::BoreMeasurement bore = jobs::MeasureBore(ev.points_mcs, nominal);
    const bool mic = r.value("size", std::string("ls")) == "mic";
    const double size = mic ? bore.diameter_mic_mm : bore.diameter_mm;
    const json& tol = jf::Object<JobInputError>(r, "tolerance", "request");
    const jobs::SizeSpec spec{nominal.diameter_mm,
                              jf::Number<JobInputError>(tol, "upper_mm", "request.tolerance"),
                              jf::Number<JobInputError>(tol, "lower_mm", "request.tolerance")};
    // A bore's diameter onto a radius offset: half the error (jobs::Feedback).
    const jobs::Feedback fb = ParseUpdate(r, 0.5);
    const jobs::SizeDecision d = jobs::DecideSize(size, spec, fb);
    const Vec3& c = bore.top_centre_mcs;
    reply.update({{"feature", "bore"},
                  {"calibration_id", cal->calibration_id},
                  {"diameter_mm", bore.diameter_mm},
                  {"diameter_mic_mm", bore.diameter_mic_mm},
                  {"size_mm", size},
                  {"centre_mm", {c.x(), c.y(), c.z()}},
                  {"rms_mm", bore.rms_mm},
                  {"points", bore.points},
                  {"arc_span_deg", bore.arc_span_deg},
                  {"error_mm", d.error_mm},
                  {"verdict", jobs::ToString(d.verdict)},
                  {"reason", d.reason},
                  {"offset_change_mm", d.offset_change_mm},
                  {"time_utc", history::UtcNow()}});
    ctx.history.AddResult(job, {"bore",
                                reply,
                                {{"verdict", jobs::ToString(d.verdict)},
                                 {"error_mm", d.error_mm},
                                 {"offset_change_mm", d.offset_change_mm},
                                 {"reason", d.reason}}});
    jobs::FitEvidence fe;
    fe.points = bore.points;
    fe.arc_span_deg = bore.arc_span_deg;
    fe.rms_mm = bore.rms_mm;
    fe.calibration_probe = cal->probe_serial;
    fe.job_probe = ev.probe_serial;
    fe.calibration_age_h = AgeHours(cal->created_utc);
    if (d.update) fe.offset_changes_mm = {d.offset_change_mm};
    const auto problems = jobs::PlausibilityProblems(fe, m.limits);
    if (!problems.empty()) {
      reply["problems"] = problems;
      reply["error"] = "nothing written: " + problems.front();
      return run.Finish(history::JobStatus::kRefused, false);
    }
    nc::NcResult out;
    out.header =
        "mlprobe job " + std::to_string(job) + ": bore " + reply["verdict"].get<std::string>();
    out.named = {{"status", d.verdict == jobs::Verdict::kInTolerance ? 0.0 : 1.0},
                 {"diameter", size},
                 {"error", d.error_mm}};
    if (m.controller.kind != ControllerConfig::Kind::kLinuxCnc) out.named.clear();
    if (d.update) {
      std::string note;
      const nc::ToolOffsetChange t =
          ResolveToolChange(m.controller, fb.offset_number, fb.reg, d.offset_change_mm, &note);
      out.tools.push_back(t);
      reply["update"] = {{"offset", t.tool},
                         {"register", nc::ToString(t.reg)},
                         {"before_mm", t.incremental ? json() : json(t.before_mm)},
                         {"after_mm", t.incremental ? json() : json(t.after_mm)},
                         {"change_mm", d.offset_change_mm}};
      if (!note.empty()) reply["update"]["note"] = note;
    }
    reply["report"] = WriteReport(ctx, job, bore, spec, size, d, reply);
    const bool alarm = d.verdict == jobs::Verdict::kUpperLimitExceeded;
    if (alarm) reply["alarm"] = d.reason;
    reply["files"] = WriteResult(m.controller, m.name, job, out, reply);
    for (const auto& t : out.tools)
      ctx.history.AddOffsetWrite(
          job, {m.name + ":" + reply["files"].at(0).get<std::string>(),
                "offset " + std::to_string(t.tool) + " " + nc::ToString(t.reg),
                t.incremental ? json() : json(t.before_mm),
                t.incremental ? json{{"change_mm", t.after_mm - t.before_mm}} : json(t.after_mm)});
    return run.Finish(d.verdict == jobs::Verdict::kInTolerance
                          ? history::JobStatus::kInTolerance
                          : history::JobStatus::kOutOfTolerance,
                      true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
