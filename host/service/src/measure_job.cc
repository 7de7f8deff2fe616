#include "mlp/base/check.h"
#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/features/decision.h"
#include "mlp/features/feature.h"
#include "mlp/features/report.h"
#include "mlp/nc/tool_table.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <array>
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

// A measure request: read once, every field checked, before any capture is loaded.
struct ToolUpdateRequest {
  int offset = 0;
  nc::ToolRegister reg = nc::ToolRegister::kRadiusWear;
  features::Feedback
      feedback;  ///< percent, null band, upper limit, experience (change_per_error later)
};

struct WorkUpdateRequest {
  int offset = 0;
  std::array<bool, 3> axes{};
};

struct MeasureRequest {
  FeatureRequest feature;
  std::optional<ToolUpdateRequest> update;
  std::optional<WorkUpdateRequest> update_work;
  bool report = true;
};

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

// The updates asked for, against what the feature can move: a tool offset (its length or its
// radius) and a work offset (from its position).
void CheckUpdatesFit(const MeasureRequest& m) {
  const std::string& feature = m.feature.nominal.feature;
  const FeatureTraits& t = m.feature.traits;
  if (m.update) {
    if (!t.change_per_error)
      throw JobInputError("request.update: a " + feature + " moves no tool offset (report only)");
    const bool length_register = m.update->reg == nc::ToolRegister::kLengthGeometry ||
                                 m.update->reg == nc::ToolRegister::kLengthWear;
    if (length_register != t.moves_length)
      throw JobInputError("request.update.register: a " + feature + " moves a tool's " +
                          (t.moves_length ? "length" : "radius") + ", not its " +
                          (length_register ? "length" : "radius"));
  }
  if (m.update_work && !t.has_position)
    throw JobInputError("request.update_work: a " + feature + " has no position to set");
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
  CheckUpdatesFit(m);
  return m;
}

// The feedback for the decision: none (report only), or the update asked for (CheckUpdatesFit).
features::Feedback FeedbackFor(const std::optional<ToolUpdateRequest>& u, const Measured& ms) {
  if (!u) return {};
  features::Feedback f = u->feedback;
  f.change_per_error = *ms.traits.change_per_error;
  return f;
}

// The work offset change asked for: where the feature was found against its nominal.
std::optional<nc::WorkOffsetChange> WorkChangeFor(const std::optional<WorkUpdateRequest>& u,
                                                  const Measured& ms) {
  if (!u) return std::nullopt;
  MLP_CHECK(ms.found_mcs.has_value());  // traits.has_position, checked with the request
  nc::WorkOffsetChange w;
  w.index = u->offset;
  w.incremental = true;
  const geometry::Vec3 shift = *ms.found_mcs - ms.nominal_mcs;
  for (int a = 0; a < 3; ++a) {
    w.axes[a] = u->axes[static_cast<size_t>(a)];
    w.after_mm[a] = w.axes[a] ? shift[a] : 0.0;
  }
  return w;
}

// The feature's numbers, a line each, as the picture lists them ("width 16.0140 mm"). Built
// with streams: GCC 12 warns falsely (-Wrestrict) on long std::string + chains.
std::vector<std::string> Lines(const Measured& ms, const features::SizeDecision& d) {
  const bool deg = ms.traits.unit == "deg";
  std::vector<std::string> out;
  std::ostringstream l;
  l << std::fixed << std::setprecision(4) << "size " << ms.size << " " << ms.traits.unit
    << " (nominal " << ms.spec.nominal_mm << " +" << ms.spec.upper_tol_mm << "/-"
    << ms.spec.lower_tol_mm << ")";
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
                        const features::SizeDecision& d,
                        const json& reply) {
  const std::string title =
      "job " + std::to_string(job) + " - " + ms.feature + " - " + ctx.machine.name;
  std::string svg;
  if (ms.bore) {
    features::BoreReport rep;
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
    svg = features::BoreReportSvg(rep);
  } else {
    features::FeatureReport rep;
    rep.title = title;
    rep.verdict = reply.value("verdict", "");
    rep.decision = reply.value("reason", "");
    rep.time_utc = reply.value("time_utc", "");
    rep.lines = Lines(ms, d);
    rep.panels = ms.panels;
    svg = features::FeatureReportSvg(rep);
  }
  const std::filesystem::path dir(ctx.config.ReportDir());
  std::filesystem::create_directories(dir);
  std::string path = (dir / (ctx.machine.name + "-job" + std::to_string(job) + ".svg")).string();
  base::WriteFileAtomically(path, svg);
  return path;
}

// The verdict in words: out of tolerance too when another tolerance of the job is exceeded
// (flatness, true position, a rectangle's second size); the reason lists those first.
struct Outcome {
  bool in_tolerance = false;
  std::string verdict, reason;
};

Outcome OutcomeOf(const Measured& ms, const features::SizeDecision& d) {
  Outcome o;
  const bool size_ok = d.verdict == features::Verdict::kInTolerance;
  o.in_tolerance = size_ok && ms.problems.empty();
  o.verdict = size_ok && !ms.problems.empty() ? std::string("out of tolerance")
                                              : features::ToString(d.verdict);
  for (const auto& p : ms.problems) o.reason += p + "; ";
  o.reason += d.reason;
  return o;
}

json ResultFields(const Measured& ms,
                  const calib::CalibrationRecord& cal,
                  const features::SizeDecision& d,
                  const Outcome& o) {
  json fields = ms.fields;
  fields.update({{"feature", ms.feature},
                 {"calibration_id", cal.calibration_id},
                 {"size_" + ms.traits.unit, ms.size},
                 {"error_" + ms.traits.unit, d.error_mm},
                 {"verdict", o.verdict},
                 {"reason", o.reason},
                 {"offset_change_mm", d.offset_change_mm},
                 {"time_utc", base::UtcTimestamp()}});
  return fields;
}

// Everything the gate weighs: the fit's evidence, the calibration, every change to be written.
features::FitEvidence GateEvidence(const Measured& ms,
                                   const calib::CalibrationRecord& cal,
                                   const Evidence& ev,
                                   const features::SizeDecision& d,
                                   const std::optional<nc::WorkOffsetChange>& work) {
  features::FitEvidence fe = ms.fe;
  fe.calibration_probe = cal.probe_serial;
  fe.job_probe = ev.probe_serial;
  fe.calibration_age_h = AgeHours(cal.created_utc);
  if (d.update) fe.offset_changes_mm = {d.offset_change_mm};
  if (work)
    fe.work_shift_mm =
        geometry::Vec3(work->after_mm[0], work->after_mm[1], work->after_mm[2]).norm();
  return fe;
}

// What goes to the controller (the macro's parameters, the tool change, the work offset
// change), each also said in the reply. Beyond the upper tolerance limit the feature is not
// what the program expects: no work offset follows it.
nc::NcResult ControllerResult(const MachineConfig& m,
                              std::int64_t job,
                              const Measured& ms,
                              const features::SizeDecision& d,
                              const Outcome& o,
                              const features::Feedback& fb,
                              const std::optional<nc::WorkOffsetChange>& work,
                              json* reply) {
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": " + ms.feature + " " + o.verdict;
  if (m.controller.kind == ControllerConfig::Kind::kLinuxCnc)
    out.named = {{"status", o.in_tolerance ? 0.0 : 1.0},
                 {ms.traits.size_name, ms.size},
                 {"error", d.error_mm}};
  if (d.update) {
    std::string note;
    const nc::ToolOffsetChange t =
        ResolveToolChange(m.controller, fb.offset_number, fb.reg, d.offset_change_mm, &note);
    out.tools.push_back(t);
    (*reply)["update"] = {{"offset", t.tool},
                          {"register", nc::ToString(t.reg)},
                          {"before_mm", t.incremental ? json() : json(t.before_mm)},
                          {"after_mm", t.incremental ? json() : json(t.after_mm)},
                          {"change_mm", d.offset_change_mm}};
    if (!note.empty()) (*reply)["update"]["note"] = note;
  }
  if (work && d.verdict != features::Verdict::kUpperLimitExceeded) {
    out.work.push_back(*work);
    (*reply)["update_work"] = {
        {"offset", work->index},
        {"shift_mm", {work->after_mm[0], work->after_mm[1], work->after_mm[2]}}};
  }
  return out;
}

}  // namespace

// The pipeline: request -> evidence -> measure -> decide -> record -> gate -> write -> record.
json RunMeasureJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "measure", r);
  json& reply = run.reply;
  try {
    const MeasureRequest request = ParseMeasureRequest(r, ctx.config.data_dir);
    const calib::CalibrationRecord& cal = run.Calibration();
    const Evidence ev = LoadCaptures(ctx, r.at("captures"), cal.flange_from_probe, run.job);
    const Measured ms = MeasureFeature(request.feature, ev);
    const features::Feedback fb = FeedbackFor(request.update, ms);
    const auto work = WorkChangeFor(request.update_work, ms);
    const features::SizeDecision d = features::DecideSize(ms.size, ms.spec, fb);
    const Outcome o = OutcomeOf(ms, d);
    reply.update(ResultFields(ms, cal, d, o));
    ctx.history.AddResult(run.job, {ms.feature,
                                    reply,
                                    {{"verdict", o.verdict},
                                     {"error_" + ms.traits.unit, d.error_mm},
                                     {"offset_change_mm", d.offset_change_mm},
                                     {"reason", o.reason}}});
    const auto problems =
        features::PlausibilityProblems(GateEvidence(ms, cal, ev, d, work), ctx.machine.limits);
    if (!problems.empty()) return run.Refuse(problems);
    const nc::NcResult out = ControllerResult(ctx.machine, run.job, ms, d, o, fb, work, &reply);
    if (request.report) reply["report"] = WriteReport(ctx, run.job, ms, d, reply);
    if (d.verdict == features::Verdict::kUpperLimitExceeded) reply["alarm"] = d.reason;
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
