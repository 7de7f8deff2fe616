#include "mlp/features/decision.h"

#include <cmath>
#include <iomanip>
#include <sstream>
#include <stdexcept>

namespace mlp::features {
namespace {

std::string Um(double mm) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1) << mm * 1e3 << " um";
  return s.str();
}

void Check(bool ok, const std::string& what) {
  if (!ok) throw DecisionError(what);
}

}  // namespace

std::string ToString(Verdict v) {
  switch (v) {
    case Verdict::kInTolerance:
      return "in tolerance";
    case Verdict::kOutOfTolerance:
      return "out of tolerance";
    case Verdict::kUpperLimitExceeded:
      return "upper tolerance limit exceeded";
  }
  return "?";
}

SizeDecision DecideSize(double measured_mm, const SizeSpec& spec, const Feedback& f) {
  Check(std::isfinite(measured_mm) && std::isfinite(spec.nominal_mm), "size: not a finite number");
  Check(spec.upper_tol_mm >= 0 && spec.lower_tol_mm >= 0 && std::isfinite(spec.upper_tol_mm) &&
            std::isfinite(spec.lower_tol_mm),
        "tolerances are magnitudes: finite and >= 0");
  Check(f.percent > 0 && f.percent <= 100, "feedback percentage must be in (0, 100]");
  Check(f.null_band_mm >= 0 && f.upper_limit_mm > f.null_band_mm,
        "null band must be >= 0 and below the upper tolerance limit");
  Check(std::isfinite(f.experience_mm) && std::isfinite(f.change_per_error),
        "experience value and change per error must be finite");
  SizeDecision d;
  d.measured_mm = measured_mm + f.experience_mm;
  d.error_mm = d.measured_mm - spec.nominal_mm;
  const double e = std::abs(d.error_mm);
  if (e > f.upper_limit_mm) {
    d.verdict = Verdict::kUpperLimitExceeded;
    d.reason = "error " + Um(d.error_mm) + " beyond the upper tolerance limit " +
               Um(f.upper_limit_mm) + ": no update";
    return d;
  }
  const bool inside = d.error_mm <= spec.upper_tol_mm && d.error_mm >= -spec.lower_tol_mm;
  d.verdict = inside ? Verdict::kInTolerance : Verdict::kOutOfTolerance;
  if (f.offset_number == 0) {
    d.reason = "report only";
    return d;
  }
  if (e < f.null_band_mm) {
    d.reason =
        "error " + Um(d.error_mm) + " inside the null band " + Um(f.null_band_mm) + ": no update";
    return d;
  }
  d.update = true;
  d.offset_change_mm = f.change_per_error * d.error_mm * f.percent / 100.0;
  std::ostringstream r;
  r << "error " << Um(d.error_mm) << ": " << nc::ToString(f.reg) << " " << f.offset_number
    << " changes by " << Um(d.offset_change_mm) << " (" << f.percent << " % feedback)";
  d.reason = r.str();
  return d;
}

std::vector<std::string> PlausibilityProblems(const FitEvidence& e, const PlausibilityLimits& l) {
  std::vector<std::string> out;
  std::ostringstream s;
  const auto add = [&](const std::string& text) { out.push_back(text); };
  if (e.points < l.min_points)
    add(std::to_string(e.points) + " points, at least " + std::to_string(l.min_points) + " needed");
  if (e.arc_span_deg && *e.arc_span_deg < l.min_arc_span_deg) {
    s.str("");
    s << "the points cover " << std::fixed << std::setprecision(0) << *e.arc_span_deg
      << " deg of the circle, at least " << l.min_arc_span_deg << " deg needed";
    add(s.str());
  }
  if (e.area_mm2 && *e.area_mm2 < l.min_area_mm2) {
    s.str("");
    s << "the points cover " << *e.area_mm2 << " mm2, at least " << l.min_area_mm2 << " mm2 needed";
    add(s.str());
  }
  if (!e.converged)
    add("a fit stopped at its iteration limit before converging: its values are an estimate");
  if (!(e.rms_mm <= l.max_rms_mm))
    add("fit residual RMS " + Um(e.rms_mm) + " above the limit " + Um(l.max_rms_mm));
  if (e.calibration_probe.empty())
    add("no calibration for probe " + e.job_probe);
  else if (e.calibration_probe != e.job_probe)
    add("the calibration is for probe " + e.calibration_probe + ", the job used " + e.job_probe);
  else if (!(e.calibration_age_h <= l.max_calibration_age_h)) {
    s.str("");
    s << "the calibration is " << std::fixed << std::setprecision(1) << e.calibration_age_h
      << " h old, the limit is " << l.max_calibration_age_h << " h";
    add(s.str());
  }
  for (double c : e.offset_changes_mm) {
    if (!(std::abs(c) <= l.max_offset_change_mm))
      add("an offset change of " + Um(c) + " exceeds the machine's limit " +
          Um(l.max_offset_change_mm));
  }
  if (e.work_shift_mm && !(*e.work_shift_mm <= l.max_work_shift_mm)) {
    s.str("");
    s << "the work origin is " << std::fixed << std::setprecision(3) << *e.work_shift_mm
      << " mm from where it was expected, the limit is " << l.max_work_shift_mm << " mm";
    add(s.str());
  }
  if (e.tilt_deg && !(*e.tilt_deg <= l.max_tilt_deg)) {
    s.str("");
    s << "the part is tilted " << std::fixed << std::setprecision(3) << *e.tilt_deg
      << " deg, more than the " << l.max_tilt_deg << " deg a rotation about Z can leave";
    add(s.str());
  }
  return out;
}

}  // namespace mlp::features
