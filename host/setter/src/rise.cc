#include "mlp/setter/rise.h"

#include <cmath>

#include <Eigen/Dense>

namespace mlp::setter {

RiseFinder::RiseFinder(double half_share, double min_s) : level_(1 + half_share), min_s_(min_s) {}

bool RiseFinder::Add(double t, double y) {
  if (found_) return false;
  if (y > level_) {
    if (!in_) {
      in_ = true, t0_ = t;
      for (double& s : s_) s = 0;
      for (double& s : sy_) s = 0;
    }
    // tau in ms from the bump's start keeps the sums' powers well scaled.
    const double tau = (t - t0_) * 1e3;
    double p = 1;
    for (int k = 0; k < 5; ++k) {
      s_[k] += p;
      if (k < 3) sy_[k] += p * y;
      p *= tau;
    }
    last_t_ = t;
    return false;
  }
  if (!in_) return false;
  in_ = false;
  if (last_t_ - t0_ < min_s_) return false;  // a noise spike, not the rise
  Eigen::Matrix3d a;
  a << s_[0], s_[1], s_[2], s_[1], s_[2], s_[3], s_[2], s_[3], s_[4];
  const Eigen::Vector3d coef = a.ldlt().solve(Eigen::Vector3d(sy_[0], sy_[1], sy_[2]));
  if (!(coef(2) < 0) || !coef.allFinite()) return false;  // not a peak
  const double vertex_ms = -coef(1) / (2 * coef(2));
  if (vertex_ms < 0 || vertex_ms > (last_t_ - t0_) * 1e3) return false;
  peak_t_ = t0_ + vertex_ms * 1e-3;
  found_ = true;
  return true;
}

}  // namespace mlp::setter
