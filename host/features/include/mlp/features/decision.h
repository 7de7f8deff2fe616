#pragma once
/// @file From a measured size to an offset change, in the vocabulary of on-machine probing
/// macros (Renishaw Inspection Plus and its kin): nominal and tolerance, experience value,
/// feedback percentage, null band, upper tolerance limit, and the tool offset to correct. Plus
/// the plausibility gate every write passes: enough points and coverage, a residual RMS below a
/// limit, a calibration valid for this probe and not too old, a change within the machine's
/// safety limit. Pure functions: the job runner applies the decision, the adapters write it.

#include "mlp/nc/offsets.h"

#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::features {

/// A size (diameter, width, length, height) and its tolerance band around the nominal.
struct SizeSpec {
  double nominal_mm = 0.0;
  double upper_tol_mm = 0.0;  ///< allowed above nominal (>= 0)
  double lower_tol_mm = 0.0;  ///< allowed below nominal (>= 0, as a magnitude)
};

/// Which offset the size error corrects and how much of it.
struct Feedback {
  int offset_number = 0;  ///< 0: report only, no offset update
  nc::ToolRegister reg = nc::ToolRegister::kRadiusWear;
  /// Offset change per unit of size error (measured - nominal): +0.5 for a bore's diameter onto
  /// a radius offset (a bore 6 um small: the radius offset drops 3 um, so with cutter
  /// compensation the tool runs 3 um further out), -0.5 for a boss's diameter, -1 for a face's
  /// height onto a length offset (a face 5 um high: the tool is 5 um shorter than it says).
  double change_per_error = 0.5;
  double experience_mm = 0.0;  ///< added to the measured size (known systematic error)
  double percent = 100.0;      ///< feedback percentage: share of the error applied (0..100]
  double null_band_mm = 0.0;   ///< |error| below: no update
  double upper_limit_mm = std::numeric_limits<double>::infinity();  ///< |error| above: alarm
};

enum class Verdict {
  kInTolerance,
  kOutOfTolerance,      ///< outside the band, within the upper tolerance limit
  kUpperLimitExceeded,  ///< beyond the upper tolerance limit: no update, alarm
};
std::string ToString(Verdict v);

struct SizeDecision {
  double measured_mm = 0.0;  ///< as measured + experience value
  double error_mm = 0.0;     ///< measured - nominal
  Verdict verdict = Verdict::kInTolerance;
  bool update = false;
  double offset_change_mm = 0.0;  ///< to add to the register (0 without update)
  std::string reason;             ///< why (no) update, for the report
};

/// A size spec or feedback that is not meaningful: the request's, refused before anything is
/// written.
class DecisionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Throws DecisionError for a spec or feedback that is not meaningful (negative tolerances,
/// percent outside (0, 100], a non-finite size).
SizeDecision DecideSize(double measured_mm, const SizeSpec& spec, const Feedback& feedback);

/// The gate before any write. Each limit names its unit.
struct PlausibilityLimits {
  int min_points = 200;
  double min_arc_span_deg = 180.0;  ///< circles and bores
  double min_area_mm2 = 0.0;        ///< planes
  double max_rms_mm = 0.010;
  double max_calibration_age_h = 24.0 * 30;
  double max_offset_change_mm = 0.2;  ///< machine safety: no single write moves more
  double max_work_shift_mm = 5.0;     ///< alignment: found origin vs the expected one
  double max_tilt_deg = 0.5;  ///< alignment on a machine that turns work offsets about Z only
};

struct FitEvidence {
  int points = 0;
  bool converged = true;  ///< every fit behind the result reached a stationary point
  std::optional<double> arc_span_deg, area_mm2;
  double rms_mm = 0.0;
  std::string calibration_probe, job_probe;
  double calibration_age_h = 0.0;
  std::vector<double> offset_changes_mm;  ///< every change the job would write
  std::optional<double> work_shift_mm;    ///< alignment: |origin found - origin expected|
  std::optional<double> tilt_deg;         ///< alignment: work Z against machine Z
};

/// Empty: fine; otherwise every reason the job must not write (all of them, not the first).
std::vector<std::string> PlausibilityProblems(const FitEvidence& e, const PlausibilityLimits& l);

}  // namespace mlp::features
