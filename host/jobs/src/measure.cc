#include "mlp/jobs/measure.h"

#include "mlp/base/check.h"
#include "mlp/features/report.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

namespace mlp::jobs {
namespace {

bool IsLengthRegister(nc::ToolRegister r) {
  return r == nc::ToolRegister::kLengthGeometry || r == nc::ToolRegister::kLengthWear;
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

// Everything the gate weighs: the fit's evidence, the calibration, every change to be written.
features::FitEvidence GateEvidence(const MeasureOutcome& o,
                                   const CalibrationFacts& cal,
                                   const Evidence& ev) {
  features::FitEvidence fe = o.measured.fe;
  fe.calibration_probe = cal.probe_serial;
  fe.job_probe = ev.probe_serial;
  fe.calibration_age_h = cal.age_h;
  if (o.decision.update) fe.offset_changes_mm = {o.decision.offset_change_mm};
  if (o.work)
    fe.work_shift_mm =
        geometry::Vec3(o.work->after_mm[0], o.work->after_mm[1], o.work->after_mm[2]).norm();
  return fe;
}

// The name of a reading as a line of the picture says it: "face_plus" -> "face plus", its
// unit from the name's ending ("diameter_mm" -> "diameter", "mm").
std::pair<std::string, std::string> NameAndUnit(std::string name) {
  std::string unit;
  for (const std::string sfx : {"_mm2", "_mm", "_deg"}) {
    if (name.size() > sfx.size() && name.compare(name.size() - sfx.size(), sfx.size(), sfx) == 0) {
      name.resize(name.size() - sfx.size());
      unit.assign(sfx, 1);
      break;
    }
  }
  std::replace(name.begin(), name.end(), '_', ' ');
  return {name, unit};
}

// The feature's numbers, a line each in the order of their names, as the picture lists them
// ("width 16.0140 mm"); groups and lists are the reply's, not the picture's. Built with
// streams: GCC 12 warns falsely (-Wrestrict) on long std::string + chains.
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
  std::vector<const Reading*> sorted;
  for (const Reading& r : ms.readings) sorted.push_back(&r);
  std::sort(sorted.begin(), sorted.end(),
            [](const Reading* a, const Reading* b) { return a->name < b->name; });
  for (const Reading* r : sorted) {
    const auto [name, unit] = NameAndUnit(r->name);
    l.str("");
    l << std::setprecision(4) << name;
    if (const auto* v = std::get_if<double>(&r->value))
      l << " " << *v << " " << unit;
    else if (const auto* n = std::get_if<std::int64_t>(&r->value))
      l << " " << *n;
    else if (const auto* p = std::get_if<geometry::Vec3>(&r->value))
      l << " X " << p->x() << "  Y " << p->y() << "  Z " << p->z();
    else
      continue;
    out.push_back(l.str());
  }
  return out;
}

}  // namespace

void CheckUpdatesFit(const MeasureRequest& m) {
  const std::string& feature = m.feature.nominal.feature;
  const FeatureTraits& t = m.feature.traits;
  if (m.update) {
    if (!t.change_per_error)
      throw RequestError("request.update: a " + feature + " moves no tool offset (report only)");
    const bool length_register = IsLengthRegister(m.update->reg);
    if (length_register != t.moves_length)
      throw RequestError("request.update.register: a " + feature + " moves a tool's " +
                         (t.moves_length ? "length" : "radius") + ", not its " +
                         (length_register ? "length" : "radius"));
  }
  if (m.update_work && !t.has_position)
    throw RequestError("request.update_work: a " + feature + " has no position to set");
}

MeasureOutcome AssessMeasure(const MeasureRequest& request,
                             const Evidence& evidence,
                             const CalibrationFacts& calibration,
                             const features::PlausibilityLimits& limits) {
  MeasureOutcome o;
  o.measured = MeasureFeature(request.feature, evidence);
  const Measured& ms = o.measured;
  o.feedback = FeedbackFor(request.update, ms);
  o.work = WorkChangeFor(request.update_work, ms);
  o.decision = features::DecideSize(ms.size, ms.spec, o.feedback);
  const bool size_ok = o.decision.verdict == features::Verdict::kInTolerance;
  o.in_tolerance = size_ok && ms.problems.empty();
  o.verdict = size_ok && !ms.problems.empty() ? std::string("out of tolerance")
                                              : features::ToString(o.decision.verdict);
  for (const auto& p : ms.problems) o.reason += p + "; ";
  o.reason += o.decision.reason;
  o.refusal = features::PlausibilityProblems(GateEvidence(o, calibration, evidence), limits);
  return o;
}

nc::NcResult MeasureChanges(const MeasureOutcome& o,
                            std::int64_t job,
                            bool named_parameters,
                            const std::optional<nc::ToolOffsetChange>& tool) {
  MLP_CHECK(o.refusal.empty());  // the gate refused: nothing goes to the machine
  MLP_CHECK(tool.has_value() == o.decision.update);  // the decision's change, or none
  const Measured& ms = o.measured;
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": " + ms.feature + " " + o.verdict;
  if (named_parameters)
    out.named = {{"status", o.in_tolerance ? 0.0 : 1.0},
                 {ms.traits.size_name, ms.size},
                 {"error", o.decision.error_mm}};
  if (tool) out.tools.push_back(*tool);
  if (o.work && o.decision.verdict != features::Verdict::kUpperLimitExceeded)
    out.work.push_back(*o.work);
  return out;
}

std::string MeasureReportSvg(const MeasureOutcome& o,
                             const std::string& title,
                             const std::string& time_utc) {
  const Measured& ms = o.measured;
  if (ms.bore) {
    features::BoreReport rep;
    rep.title = title;
    rep.boss = ms.feature == "boss";
    rep.nominal_mm = ms.spec.nominal_mm;
    rep.upper_tol_mm = ms.spec.upper_tol_mm;
    rep.lower_tol_mm = ms.spec.lower_tol_mm;
    rep.bore = *ms.bore;
    rep.size_mm = ms.size;
    rep.error_mm = o.decision.error_mm;
    rep.verdict = o.verdict;
    rep.decision = o.reason;
    rep.time_utc = time_utc;
    return features::BoreReportSvg(rep);
  }
  features::FeatureReport rep;
  rep.title = title;
  rep.verdict = o.verdict;
  rep.decision = o.reason;
  rep.time_utc = time_utc;
  rep.lines = Lines(ms, o.decision);
  rep.panels = ms.panels;
  return features::FeatureReportSvg(rep);
}

}  // namespace mlp::jobs
