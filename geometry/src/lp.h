#pragma once
// Linear programs with few variables (d <= 5) and many constraints: min c.x s.t. A x <= b,
// |x_k| <= bound_k.
//
// Why by hand: the Chebyshev fits (minimum zone, inscribed, circumscribed) are LPs of 3-4
// variables over every measured point. None of the project's libraries has an LP solver, and a
// general one (GLPK, CLP) would be a heavy new dependency for the Eigen-only geometry layer. The
// method is the simplex method applied to the dual, whose basis is just d active constraints:
// each pivot brings in the most violated point (the exchange algorithm of Chebyshev
// approximation, Stiefel 1959), so it finishes in a few dozen pivots for thousands of points.

#include <Eigen/Core>

namespace mlp::geometry::internal {

struct LpResult {
  Eigen::VectorXd x;
  bool optimal = false;            // false: iteration limit or an infeasible system
  std::vector<bool> bound_active;  // per variable: the optimum lies on |x_k| = bound_k
};

/// Solves min c.x s.t. a.row(i) x <= b(i), -bound_k <= x_k <= bound_k.
LpResult SolveSmallLp(const Eigen::VectorXd& c,
                      const Eigen::MatrixXd& a,
                      const Eigen::VectorXd& b,
                      const Eigen::VectorXd& bound);

}  // namespace mlp::geometry::internal
