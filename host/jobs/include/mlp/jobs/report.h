#pragma once
/// @file Pictures a person reads at the machine (SVG: any browser or the controller's file
/// viewer shows it, and it stays sharp when zoomed): the fitted feature, its deviations
/// colour-mapped and magnified, the nominal and its tolerance, the numbers and the verdict.

#include "mlp/jobs/feature.h"

#include <string>

namespace mlp::jobs {

struct BoreReport {
  std::string title;  ///< e.g. "job 42 - bore - vmc-1"
  double nominal_mm = 0, upper_tol_mm = 0, lower_tol_mm = 0;
  BoreMeasurement bore;
  double size_mm = 0, error_mm = 0;
  std::string verdict;   ///< "in tolerance", "out of tolerance", ...
  std::string decision;  ///< what was (not) written and why
  std::string time_utc;
};

/// A roundness plot: the least-squares circle, the mean radial deviation per degree magnified
/// (blue inside, red outside the fitted circle), the nominal and its tolerance band at the same
/// magnification, and the numbers.
std::string BoreReportSvg(const BoreReport& report);

}  // namespace mlp::jobs
