#pragma once
/// @file What a trunnion check reports (issue 54), one writer for `mlp kinematics check` and
/// the service's kinematics job: the pivots against the controller's pins, the squareness its
/// kinematics cannot hold, each against its limit; as JSON and as a picture (SVG).

#include "mlp/calib/trunnion.h"

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::calib {

struct TrunnionLimits {
  double pivot_mm = 0.010;   ///< largest pivot error accepted
  double square_deg = 0.01;  ///< largest squareness accepted
};

/// Every pivot and squareness within its limit.
bool TrunnionWithin(const TrunnionFit& fit, const TrtPins& pins, const TrunnionLimits& limits);

/// {"within", "centres", "residual_rms_mm", "residual_mm", "pivots_mm": [{"name",
/// "controller", "found", "error", "u", "limit", "within"}], "squareness_deg": [...],
/// "pins_that_fit"}.
/// A calibration's pins as JSON (the job's reply and `mlp kinematics calibrate --json`):
/// [{"name", "before_mm", "after_mm", "u_mm", "changed"}, ...].
nlohmann::json PinChangesJson(const std::vector<PinChange>& changes);

nlohmann::ordered_json TrunnionReportJson(const std::vector<TrunnionObservation>& centres,
                                          const TrunnionFit& fit,
                                          const TrtPins& pins,
                                          const TrunnionLimits& limits);

/// The report for a person: one line per pivot and squareness, BEYOND where over its limit.
std::string TrunnionReportText(const std::vector<TrunnionObservation>& centres,
                               const TrunnionFit& fit,
                               const TrtPins& pins,
                               const TrunnionLimits& limits);

/// The picture of a check: the centres per A/C position and the fitted circles' axes seen
/// along X and along Z, each centre's residual magnified, the pivots' errors against the limit.
std::string TrunnionSvg(const std::vector<TrunnionObservation>& centres,
                        const TrunnionFit& fit,
                        const TrtPins& pins,
                        double limit_mm);

}  // namespace mlp::calib
