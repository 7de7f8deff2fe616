#include "lp.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/LU>

namespace mlp::geometry::internal {
namespace {

constexpr size_t kWorkingSetGrowth = 64;  // violated rows added per full scan
// A pivot whose dual step is below this (relative to the dual values) is degenerate: a step of
// rounding noise moves nothing, and counting it as progress let Dantzig's rule cycle for 100,000
// pivots on the 106,922 wall points of Hostd.MeasuresABoreAndWritesTheOffsetForLinuxCnc (clang
// build) and on an exact 90-degree grid of a cylinder with a 3-lobe form (tests/geometry).
constexpr double kTieRelative = 1e-12;
constexpr int kDegenerateRun = 20;  // degenerate pivots in a row before Bland's rule

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

// The data rows the pivots look at. Few points are ever active (the extremes), so pivots cost
// O(working set), not O(points); only when the set is satisfied are all rows scanned.
struct WorkingSet {
  std::vector<Eigen::Index> rows;
  std::vector<bool> in;

  // The worst violated rows not yet in the set join it (kWorkingSetGrowth at most); returns
  // the worst of them, -1 when every row is satisfied.
  Eigen::Index Grow(const Eigen::MatrixXd& a,
                    const Eigen::VectorXd& b,
                    const Eigen::VectorXd& x,
                    double tol) {
    const Eigen::VectorXd viol = a * x - b;
    std::vector<Eigen::Index> violated;
    for (Eigen::Index j = 0; j < a.rows(); ++j) {
      if (viol(j) > tol && !in[static_cast<size_t>(j)]) violated.push_back(j);
    }
    const size_t add = std::min<size_t>(violated.size(), kWorkingSetGrowth);
    std::partial_sort(violated.begin(), violated.begin() + static_cast<std::ptrdiff_t>(add),
                      violated.end(),
                      [&](Eigen::Index p, Eigen::Index q) { return viol(p) > viol(q); });
    for (size_t k = 0; k < add; ++k)
      rows.push_back(violated[k]), in[static_cast<size_t>(violated[k])] = true;
    return add > 0 ? violated[0] : -1;
  }
};

// Entering row: the most violated within the working set and the bounds (Dantzig); after a run
// of degenerate pivots, the violated one of lowest index (Bland's rule, which cannot cycle:
// Bland 1977). When those are all satisfied, the worst of the rows the working set grows by
// (the set only grows, so Bland's rule holds on it once it stops growing). -1: optimal.
Eigen::Index EnteringRow(
    const Extended& ext, const Eigen::VectorXd& x, double tol, bool bland, WorkingSet* work) {
  Eigen::Index enter = -1;
  double worst = tol;
  const auto consider = [&](Eigen::Index j, double viol) {
    if (bland) {
      if (viol > tol && (enter < 0 || j < enter)) enter = j;
    } else if (viol > worst) {
      worst = viol, enter = j;
    }
  };
  for (Eigen::Index j : work->rows) consider(j, ext.a.row(j).dot(x) - ext.b(j));
  if (!bland || enter < 0) {  // a data row's index is below every bound row's
    for (Eigen::Index j = ext.a.rows(); j < ext.rows(); ++j)
      consider(j, ext.Row(j).dot(x) - ext.Rhs(j));
  }
  return enter >= 0 ? enter : work->Grow(ext.a, ext.b, x, tol);
}

// Leaving row: the ratio test on the dual values y along the entering row's direction w; ties
// (within rounding) go to the basic row of lowest index, which Bland's rule needs. -1 when the
// dual is unbounded (the constraints are infeasible); its step in *t (>= 0: a dual value
// rounded below zero is taken as zero).
Eigen::Index LeavingRow(const Eigen::VectorXd& y,
                        const Eigen::VectorXd& w,
                        const std::vector<Eigen::Index>& basis,
                        double* t) {
  Eigen::Index leave = -1;
  *t = INFINITY;
  const double tie = kTieRelative * (1.0 + y.cwiseAbs().maxCoeff());
  for (Eigen::Index i = 0; i < y.size(); ++i) {
    if (w(i) <= 1e-14) continue;
    const double ratio = std::max(y(i), 0.0) / w(i);
    const bool lower_index =
        leave >= 0 && basis[static_cast<size_t>(i)] < basis[static_cast<size_t>(leave)];
    if (leave < 0 || ratio < *t - tie || (ratio <= *t + tie && lower_index))
      *t = std::min(*t, ratio), leave = i;
  }
  return leave;
}

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
  WorkingSet work{{}, std::vector<bool>(static_cast<size_t>(a.rows()), false)};
  for (int it = 0; it < 100000; ++it) {
    for (Eigen::Index i = 0; i < d; ++i)
      rows.row(i) = ext.Row(basis[i]).transpose(), rhs(i) = ext.Rhs(basis[i]);
    const Eigen::PartialPivLU<Eigen::MatrixXd> lu(rows);
    x = lu.solve(rhs);
    const Eigen::VectorXd y = lu.transpose().solve(-c);  // dual values of the basic rows
    const Eigen::Index enter = EnteringRow(ext, x, tol, degenerate > kDegenerateRun, &work);
    if (enter < 0) {  // every row satisfied: optimal
      result.optimal = true;
      break;
    }
    double t = 0;
    const Eigen::Index leave = LeavingRow(y, lu.transpose().solve(ext.Row(enter)), basis, &t);
    if (leave < 0) break;  // dual unbounded: the constraints are infeasible
    const bool stalled = t <= kTieRelative * (1.0 + y.cwiseAbs().maxCoeff());
    degenerate = stalled ? degenerate + 1 : 0;
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
