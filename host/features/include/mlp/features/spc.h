#pragma once
/// @file Process capability of one characteristic from its measured values in time order: the
/// individuals chart's statistics and Cp / Cpk / Pp / Ppk (ISO 22514-2; AIAG SPC manual, 2nd ed.,
/// individuals and moving range). The short-term (within) sigma is the mean moving range over
/// d2 = 1.128 (ranges of two consecutive values), so a drift between parts does not inflate it;
/// the overall sigma is the sample standard deviation. Cp / Cpk use the first, Pp / Ppk the
/// second. Control limits: the mean +- 3 within-sigma.

#include "mlp/base/input_error.h"

#include <string>
#include <vector>

namespace mlp::features {

/// Values that give no capability: fewer than two, not finite, limits the wrong way round, or
/// no spread at all (every value the same: capability is undefined, not infinite).
class SpcError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct SpcLimits {
  double lower = 0.0, upper = 0.0;  ///< LSL and USL, in the values' unit
};

struct CapabilityStudy {
  int n = 0;
  double mean = 0.0;
  double sigma_within = 0.0;   ///< mean moving range / 1.128
  double sigma_overall = 0.0;  ///< sample standard deviation (n - 1)
  double cp = 0.0, cpk = 0.0, pp = 0.0, ppk = 0.0;
  double lcl = 0.0, ucl = 0.0;      ///< the individuals chart's control limits
  int out_of_spec = 0;              ///< values outside [lower, upper]
  std::vector<int> out_of_control;  ///< indices of values outside [lcl, ucl]
  /// Fewer than 25 values: the figures are said, but are not a capability statement (AIAG asks
  /// for at least 25 subgroups; individuals need more).
  bool few_values = false;
};

/// Throws SpcError as above.
CapabilityStudy StudyCapability(const std::vector<double>& values, const SpcLimits& limits);

/// The run chart as SVG text: the values in order, the mean, the control limits and the
/// specification limits; values out of specification in red. `title` heads it; `unit` labels
/// the value axis.
std::string RunChartSvg(const std::vector<double>& values,
                        const SpcLimits& limits,
                        const CapabilityStudy& study,
                        const std::string& title,
                        const std::string& unit);

}  // namespace mlp::features
