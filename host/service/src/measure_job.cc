#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/jobs/decision.h"
#include "mlp/jobs/feature.h"
#include "mlp/jobs/report.h"
#include "mlp/nc/tool_table.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <sstream>

#include "job_common.h"
#include "measure_features.h"

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

jobs::Feedback ParseUpdate(const json& r, const Measured& ms) {
  jobs::Feedback f;
  if (!r.contains("update")) return f;  // report only
  if (!ms.change_per_error)
    throw JobInputError("request.update: a " + ms.feature + " moves no tool offset (report only)");
  f.change_per_error = *ms.change_per_error;
  const json& u = jf::Object<JobInputError>(r, "update", "request");
  const std::string w = "request.update";
  f.offset_number = jf::Integer<JobInputError>(u, "offset", w);
  f.reg = RegisterOf(jf::Text<JobInputError>(u, "register", w));
  const bool length_register =
      f.reg == nc::ToolRegister::kLengthGeometry || f.reg == nc::ToolRegister::kLengthWear;
  if (length_register != ms.moves_length)
    throw JobInputError("request.update.register: a " + ms.feature + " moves a tool's " +
                        (ms.moves_length ? "length" : "radius") + ", not its " +
                        (length_register ? "length" : "radius"));
  f.percent = jf::NumberOr<JobInputError>(u, "percent", f.percent, w);
  f.null_band_mm = jf::NumberOr<JobInputError>(u, "null_band_mm", f.null_band_mm, w);
  f.upper_limit_mm = jf::NumberOr<JobInputError>(u, "upper_limit_mm", f.upper_limit_mm, w);
  f.experience_mm = jf::NumberOr<JobInputError>(u, "experience_mm", f.experience_mm, w);
  return f;
}

// The feature's numbers, a line each, as the picture lists them ("width 16.0140 mm"). Built
// with streams: GCC 12 warns falsely (-Wrestrict) on long std::string + chains.
std::vector<std::string> Lines(const Measured& ms, const jobs::SizeDecision& d) {
  const bool deg = ms.unit == "deg";
  std::vector<std::string> out;
  std::ostringstream l;
  l << std::fixed << std::setprecision(4) << "size " << ms.size << " " << ms.unit << " (nominal "
    << ms.spec.nominal_mm << " +" << ms.spec.upper_tol_mm << "/-" << ms.spec.lower_tol_mm << ")";
  out.push_back(l.str());
  l.str("");
  l << std::setprecision(1) << "error " << (deg ? d.error_mm * 3600 : d.error_mm * 1e3)
    << (deg ? " arcsec" : " um");
  out.push_back(l.str());
  for (const auto& [key, v] : ms.fields.items()) {
    std::string name = key, unit;
    for (const std::string sfx : {"_mm2", "_mm", "_deg"}) {
      if (name.size() > sfx.size() &&
          name.compare(name.size() - sfx.size(), sfx.size(), sfx) == 0) {
        name.resize(name.size() - sfx.size());
        unit.assign(sfx, 1);
        break;
      }
    }
    std::replace(name.begin(), name.end(), '_', ' ');
    l.str("");
    l << std::setprecision(4) << name;
    if (v.is_number_float())
      l << " " << v.get<double>() << " " << unit;
    else if (v.is_number_integer())
      l << " " << v.get<long long>();
    else if (v.is_array() && v.size() == 3 && v[0].is_number())
      l << " X " << v[0].get<double>() << "  Y " << v[1].get<double>() << "  Z "
        << v[2].get<double>();
    else
      continue;
    out.push_back(l.str());
  }
  return out;
}

// The picture for the operator: data_dir/reports/<machine>-job<N>.svg. A bore or boss: its
// roundness plot; the others: their surfaces' deviations and the numbers.
std::string WriteReport(JobContext& ctx,
                        std::int64_t job,
                        const Measured& ms,
                        const jobs::SizeDecision& d,
                        const json& reply) {
  const std::string title =
      "job " + std::to_string(job) + " - " + ms.feature + " - " + ctx.machine.name;
  std::string svg;
  if (ms.bore) {
    jobs::BoreReport rep;
    rep.title = title;
    rep.boss = ms.feature == "boss";
    rep.nominal_mm = ms.spec.nominal_mm;
    rep.upper_tol_mm = ms.spec.upper_tol_mm;
    rep.lower_tol_mm = ms.spec.lower_tol_mm;
    rep.bore = *ms.bore;
    rep.size_mm = ms.size;
    rep.error_mm = d.error_mm;
    rep.verdict = reply.value("verdict", "");
    rep.decision = reply.value("reason", "");
    rep.time_utc = reply.value("time_utc", "");
    svg = jobs::BoreReportSvg(rep);
  } else {
    jobs::FeatureReport rep;
    rep.title = title;
    rep.verdict = reply.value("verdict", "");
    rep.decision = reply.value("reason", "");
    rep.time_utc = reply.value("time_utc", "");
    rep.lines = Lines(ms, d);
    rep.panels = ms.panels;
    svg = jobs::FeatureReportSvg(rep);
  }
  const std::filesystem::path dir(ctx.config.ReportDir());
  std::filesystem::create_directories(dir);
  const std::string path =
      (dir / (ctx.machine.name + "-job" + std::to_string(job) + ".svg")).string();
  base::WriteFileAtomically(path, svg);
  return path;
}

// "update_work": {"offset": n, "axes": "xy"}: the work offset moved by where the feature was
// found against its nominal (a part set up on one feature), in the control (incremental).
std::optional<nc::WorkOffsetChange> ParseWorkUpdate(const json& r, const Measured& ms) {
  if (!r.contains("update_work")) return std::nullopt;
  const json& u = jf::Object<JobInputError>(r, "update_work", "request");
  if (!ms.found_mcs)
    throw JobInputError("request.update_work: a " + ms.feature + " has no position to set");
  nc::WorkOffsetChange w;
  w.index = jf::Integer<JobInputError>(u, "offset", "request.update_work");
  const std::string axes = jf::Text<JobInputError>(u, "axes", "request.update_work");
  if (axes.empty() || axes.find_first_not_of("xyz") != std::string::npos)
    throw JobInputError("request.update_work.axes: one or more of x, y, z (\"xy\")");
  w.incremental = true;
  const geometry::Vec3 shift = *ms.found_mcs - ms.nominal_mcs;
  for (int a = 0; a < 3; ++a) {
    w.axes[a] = axes.find("xyz"[a]) != std::string::npos;
    w.after_mm[a] = w.axes[a] ? shift[a] : 0.0;
  }
  return w;
}

}  // namespace

json RunMeasureJob(JobContext& ctx, const json& r) {
  const MachineConfig& m = ctx.machine;
  JobRun run(ctx, "measure", r);
  json& reply = run.reply;
  const std::int64_t job = run.job;
  try {
    CheckFeatureName(jf::Text<JobInputError>(r, "feature", "request"));
    const calib::CalibrationRecord* cal = &run.Calibration();
    if (!r.contains("captures"))
      throw JobInputError("request.captures must list the capture jobs to use");
    const Evidence ev = LoadCaptures(ctx, r.at("captures"), cal->flange_from_probe, job);
    const Measured ms = MeasureFeature(r, ev, ctx.config.data_dir);
    const jobs::Feedback fb = ParseUpdate(r, ms);
    const auto work = ParseWorkUpdate(r, ms);
    const jobs::SizeDecision d = jobs::DecideSize(ms.size, ms.spec, fb);
    const bool in_tolerance = d.verdict == jobs::Verdict::kInTolerance && ms.problems.empty();
    const std::string verdict = d.verdict == jobs::Verdict::kInTolerance && !ms.problems.empty()
                                    ? std::string("out of tolerance")
                                    : jobs::ToString(d.verdict);
    std::string reason;
    for (const auto& p : ms.problems) reason += p + "; ";
    reply.update(ms.fields);
    reply.update({{"feature", ms.feature},
                  {"calibration_id", cal->calibration_id},
                  {"size_" + ms.unit, ms.size},
                  {"error_" + ms.unit, d.error_mm},
                  {"verdict", verdict},
                  {"reason", reason + d.reason},
                  {"offset_change_mm", d.offset_change_mm},
                  {"time_utc", base::UtcTimestamp()}});
    ctx.history.AddResult(job, {ms.feature,
                                reply,
                                {{"verdict", verdict},
                                 {"error_" + ms.unit, d.error_mm},
                                 {"offset_change_mm", d.offset_change_mm},
                                 {"reason", reply["reason"]}}});
    jobs::FitEvidence fe = ms.fe;
    fe.calibration_probe = cal->probe_serial;
    fe.job_probe = ev.probe_serial;
    fe.calibration_age_h = AgeHours(cal->created_utc);
    if (d.update) fe.offset_changes_mm = {d.offset_change_mm};
    if (work)
      fe.work_shift_mm =
          geometry::Vec3(work->after_mm[0], work->after_mm[1], work->after_mm[2]).norm();
    const auto problems = jobs::PlausibilityProblems(fe, m.limits);
    if (!problems.empty()) {
      reply["problems"] = problems;
      reply["error"] = "nothing written: " + problems.front();
      return run.Finish(history::JobStatus::kRefused, false);
    }
    nc::NcResult out;
    out.header = "mlprobe job " + std::to_string(job) + ": " + ms.feature + " " + verdict;
    if (m.controller.kind == ControllerConfig::Kind::kLinuxCnc)
      out.named = {
          {"status", in_tolerance ? 0.0 : 1.0}, {ms.size_name, ms.size}, {"error", d.error_mm}};
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
    // Beyond the upper tolerance limit the feature is not what the program expects: no offset
    // follows it, the work offset neither.
    if (work && d.verdict != jobs::Verdict::kUpperLimitExceeded) {
      out.work.push_back(*work);
      reply["update_work"] = {
          {"offset", work->index},
          {"shift_mm", {work->after_mm[0], work->after_mm[1], work->after_mm[2]}}};
    }
    if (jf::FlagOr<JobInputError>(r, "report", true, "request"))
      reply["report"] = WriteReport(ctx, job, ms, d, reply);
    if (d.verdict == jobs::Verdict::kUpperLimitExceeded) reply["alarm"] = d.reason;
    std::vector<history::OffsetWriteRow> rows;
    for (const auto& t : out.tools)
      rows.push_back(
          {"", "offset " + std::to_string(t.tool) + " " + nc::ToString(t.reg),
           t.incremental ? json() : json(t.before_mm),
           t.incremental ? json{{"change_mm", t.after_mm - t.before_mm}} : json(t.after_mm)});
    for (const auto& w : out.work)
      rows.push_back({"",
                      "work offset " + std::to_string(w.index),
                      json(),
                      {{"shift_mm", {w.after_mm[0], w.after_mm[1], w.after_mm[2]}}}});
    reply["status"] = in_tolerance ? "in_tolerance" : "out_of_tolerance";  // if a stop comes
    reply["files"] = WriteToController(ctx, job, out, reply, std::move(rows));
    return run.Finish(
        in_tolerance ? history::JobStatus::kInTolerance : history::JobStatus::kOutOfTolerance,
        true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
