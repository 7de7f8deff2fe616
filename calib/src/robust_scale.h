#pragma once
// Median and the robust scale of residuals, for calib's own fits (internal to mlp_calib).

#include <algorithm>
#include <cmath>
#include <vector>

namespace mlp::calib {

/// The median (the upper one of an even count); `v` must not be empty.
inline double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// 1.4826 x the median |v|: the sigma of residuals' Gaussian core despite outliers (Rousseeuw &
/// Leroy 1987).
inline double RobustSigma(std::vector<double> v) {
  for (double& e : v) e = std::abs(e);
  return 1.4826 * Median(std::move(v));
}

}  // namespace mlp::calib
