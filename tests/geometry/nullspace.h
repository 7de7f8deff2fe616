#pragma once
// Reference data with a known least-squares solution (the null-space method used to build
// ISO 10360-6 test sets; Forbes & Minh, NPL): exact points on the shape are moved along the
// surface normal by deviations e with J^T e = 0, J being the Jacobian of the orthogonal-distance
// residuals at the true parameters. The true parameters are then a stationary point of the sum
// of squares, so a correct fit must return them to rounding level.

#include "mlp/geometry/types.h"

#include <random>

#include "seeded_draw.h"
#include <Eigen/Cholesky>

namespace mlp::test {

using geometry::Points2;
using geometry::Points3;
using geometry::Vec2;
using geometry::Vec3;

/// Random deviations of max |e| = amplitude, orthogonal to the columns of `jacobian` (n x P).
inline Eigen::VectorXd NullSpaceDeviations(const Eigen::MatrixXd& jacobian,
                                           double amplitude,
                                           std::mt19937_64& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::VectorXd e(jacobian.rows());
  for (Eigen::Index i = 0; i < e.size(); ++i) e(i) = gauss(rng);
  const Eigen::MatrixXd jtj = jacobian.transpose() * jacobian;
  const auto ldlt = jtj.ldlt();
  for (int pass = 0; pass < 2; ++pass) e -= jacobian * ldlt.solve(jacobian.transpose() * e);
  return e * (amplitude / e.cwiseAbs().maxCoeff());
}

/// Unit vectors u, v completing `w` to a right-handed frame.
inline void Frame(const Vec3& w, Vec3* u, Vec3* v) {
  *u = w.unitOrthogonal();
  *v = w.cross(*u);
}

/// A random unit vector.
inline Vec3 RandomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  return DrawVec3(g, rng).normalized();
}

}  // namespace mlp::test
