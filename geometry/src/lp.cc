#include "lp.h"

#include <cmath>
#include <vector>

#include <Eigen/LU>

namespace mlp::geometry::internal {
namespace {

// Row j of the extended system: the data rows, then +x_k <= bound_k, then -x_k <= bound_k.
struct Extended {
  const Eigen::MatrixXd& a;
  const Eigen::VectorXd& b;
  const Eigen::VectorXd& bound;
  Eigen::Index d() const { return a.cols(); }
  Eigen::Index rows() const { return a.rows() + 2 * d(); }
  Eigen::VectorXd Row(Eigen::Index j) const {
    if (j < a.rows()) return a.row(j).transpose();
    Eigen::VectorXd r = Eigen::VectorXd::Zero(d());
    const Eigen::Index k = (j - a.rows()) % d();
    r(k) = j - a.rows() < d() ? 1.0 : -1.0;
    return r;
  }
  double Rhs(Eigen::Index j) const { return j < a.rows() ? b(j) : bound((j - a.rows()) % d()); }
};

}  // namespace

LpResult SolveSmallLp(const Eigen::VectorXd& c,
                      const Eigen::MatrixXd& a,
                      const Eigen::VectorXd& b,
                      const Eigen::VectorXd& bound) {
  const Extended ext{a, b, bound};
  const Eigen::Index d = ext.d();
  // Start: the box corner that minimises c.x; its d bound rows are dual feasible (y = |c_k|).
  std::vector<Eigen::Index> basis(d);
  for (Eigen::Index k = 0; k < d; ++k) basis[k] = a.rows() + (c(k) < 0.0 ? k : d + k);
  const double scale = 1.0 + b.cwiseAbs().maxCoeff() + bound.cwiseAbs().maxCoeff();
  const double tol = 1e-13 * scale;
  LpResult result;
  Eigen::MatrixXd rows(d, d);
  Eigen::VectorXd rhs(d), x(d);
  int degenerate = 0;
  for (int it = 0; it < 100000; ++it) {
    for (Eigen::Index i = 0; i < d; ++i)
      rows.row(i) = ext.Row(basis[i]).transpose(), rhs(i) = ext.Rhs(basis[i]);
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(rows);
    x = lu.solve(rhs);
    const Eigen::VectorXd y = lu.transpose().solve(-c);  // dual values of the basic rows
    // Entering row: most violated (Dantzig), or the first violated one after a run of
    // degenerate pivots (Bland's rule, which cannot cycle).
    Eigen::Index enter = -1;
    double worst = tol;
    const Eigen::VectorXd data_viol = a * x - b;  // one pass over the data rows
    for (Eigen::Index j = 0; j < ext.rows(); ++j) {
      const double viol = j < a.rows() ? data_viol(j) : ext.Row(j).dot(x) - ext.Rhs(j);
      if (viol > worst) {
        worst = viol, enter = j;
        if (degenerate > 20) break;
      }
    }
    if (enter < 0) {
      result.optimal = true;
      break;
    }
    const Eigen::VectorXd w = lu.transpose().solve(ext.Row(enter));
    Eigen::Index leave = -1;
    double t = INFINITY;
    for (Eigen::Index i = 0; i < d; ++i) {
      if (w(i) > 1e-14 && y(i) / w(i) < t) t = y(i) / w(i), leave = i;
    }
    if (leave < 0) break;  // dual unbounded: the constraints are infeasible
    degenerate = t <= 0.0 ? degenerate + 1 : 0;
    basis[leave] = enter;
  }
  result.x = x;
  result.bound_active.assign(d, false);
  for (Eigen::Index k = 0; k < d; ++k) {
    result.bound_active[k] = std::abs(std::abs(x(k)) - bound(k)) <= 1e-9 * (1.0 + bound(k));
  }
  return result;
}

}  // namespace mlp::geometry::internal
