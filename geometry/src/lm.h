#pragma once
// Levenberg-Marquardt for small fixed-size parameter vectors and many residuals.
//
// Why not Ceres: a fit of 1e6 points with <= 6 parameters is dominated by per-residual
// overhead in a general solver; here each iteration is one pass that accumulates the P x P
// normal equations J^T J and J^T r directly (cache-friendly, no Jacobian storage), and the model
// re-linearises in a local frame each iteration (Forbes' scheme), which Ceres manifolds would
// only approximate. Ceres stays the tool for the calibration problems.

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit_result.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "kernels.h"
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

namespace mlp::geometry::internal {

template <int P>
struct NormalEquations {
  Eigen::Matrix<double, P, P> jtj = Eigen::Matrix<double, P, P>::Zero();
  Eigen::Matrix<double, P, 1> jtr = Eigen::Matrix<double, P, 1>::Zero();
  double ss = 0.0;                                          // sum of squared residuals
  double min_r = std::numeric_limits<double>::infinity();   // most negative residual
  double max_r = -std::numeric_limits<double>::infinity();  // most positive residual

  // Set by the QR polish: the Accumulator then also keeps every Jacobian row and residual.
  std::vector<Eigen::Matrix<double, P, 1>>* rows = nullptr;
  std::vector<double>* residuals = nullptr;

  // Filled by Accumulator (lower triangle); Finish mirrors it to the full matrix.
  void Finish() { jtj = jtj.template selfadjointView<Eigen::Lower>(); }
};

// Gathers Jacobian rows in a chunk (structure of arrays) and hands each full chunk to the
// vectorised AccumulateRows kernel (kernels.h): measured 2.5x faster per pass than adding each
// row to the sums in place, which a compiler cannot vectorise across points.
template <int P>
class Accumulator {
 public:
  explicit Accumulator(const NormalEquations<P>* sink)
      : rows_(sink != nullptr ? sink->rows : nullptr),
        residuals_(sink != nullptr ? sink->residuals : nullptr) {}

  [[gnu::always_inline]] void Add(const Eigen::Matrix<double, P, 1>& j, double r) {
    if (rows_ != nullptr) rows_->push_back(j), residuals_->push_back(r);
#pragma GCC unroll 8
    for (int a = 0; a < P; ++a) chunk_.j[a][count_] = j(a);
    chunk_.r[count_] = r;
    if (++count_ == kChunkRows) Flush();
  }

  /// Adds `count` rows made a chunk at a time: fill(first, m, chunk) writes the rows of points
  /// [first, first + m) into chunk.j[.][0, m) and chunk.r[0, m), in a loop over points the
  /// compiler can vectorise (sqrt and division included), unlike Add's row-at-a-time calls.
  template <class Fill>
  [[gnu::always_inline]] void AddRows(Eigen::Index count, Fill fill) {
    Flush();
    for (Eigen::Index first = 0; first < count; first += kChunkRows) {
      count_ = static_cast<int>(std::min<Eigen::Index>(kChunkRows, count - first));
      fill(first, count_, chunk_);
      if (rows_ != nullptr) {
        for (int i = 0; i < count_; ++i) {
          Eigen::Matrix<double, P, 1> row;
          for (int a = 0; a < P; ++a) row(a) = chunk_.j[a][i];
          rows_->push_back(row), residuals_->push_back(chunk_.r[i]);
        }
      }
      Flush();
    }
  }

  /// The accumulated equations; also copied into `sink` when given.
  NormalEquations<P> Finish(NormalEquations<P>* sink) {
    Flush();
    NormalEquations<P> ne;
    for (int a = 0; a < P; ++a) {
      for (int b = 0; b <= a; ++b) ne.jtj(a, b) = sums_.jtj[a][b];
      ne.jtr(a) = sums_.jtr[a];
    }
    ne.ss = sums_.ss, ne.min_r = sums_.min_r, ne.max_r = sums_.max_r;
    ne.rows = rows_, ne.residuals = residuals_;
    if (sink != nullptr) *sink = ne;
    return ne;
  }

 private:
  void Flush() {
    if (count_ > 0) AccumulateRows(chunk_, count_, &sums_);
    count_ = 0;
  }

  std::vector<Eigen::Matrix<double, P, 1>>* rows_;
  std::vector<double>* residuals_;
  RowChunk<P> chunk_;
  int count_ = 0;
  RowSums<P> sums_;
};

struct LmSummary {
  int iterations = 0;
  double ss = 0.0;
  bool converged = false;
};

// Model concept:
//   using State = ...;
//   static constexpr int kParams = P;
//   NormalEquations<P> Linearize(const State&) const;  // residuals r, Jacobian J = dr/ddelta
//   State Update(const State&, const Eigen::Matrix<double,P,1>& delta) const;
//   double StepLength(const Eigen::Matrix<double,P,1>& delta) const;  // in mm (angles x scale)
//   double Scale() const;                               // typical size of the data [mm]
// Normal equations lose about log10(cond(J)^2) digits; below cond(J) = 1e4 the rounding they
// leave is under 1e-8 of the scale and QR would change nothing measurable.
template <class Model>
bool IsIllConditioned(NormalEquations<Model::kParams> ne, const Model& model) {
  ne.Finish();
  const auto d = ne.jtj.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse().eval();
  const auto scaled = (d.asDiagonal() * ne.jtj * d.asDiagonal()).eval();
  Eigen::SelfAdjointEigenSolver<decltype(scaled)> es(scaled, Eigen::EigenvaluesOnly);
  (void)model;
  return !(es.eigenvalues()(0) > 1e-8 * es.eigenvalues()(Model::kParams - 1));
}

// Clouds up to this size get the final Gauss-Newton steps by QR of the Jacobian.
constexpr Eigen::Index kQrPolishPoints = 20000;

// Final Gauss-Newton steps solved by column-pivoted QR of the Jacobian rather than the normal
// equations: the normal equations square the condition number, which on ill-conditioned data
// (a 15 deg cone sector 1000 mm from the origin) leaves ~1e-7 rad of rounding in the axis; QR
// leaves ~1e-10 (Golub & Van Loan, section 5.3). Steps are taken while the cost stays within
// rounding and the step keeps shrinking.
template <class Model>
int PolishByQr(const Model& model,
               typename Model::State& state,
               NormalEquations<Model::kParams>& ne) {
  constexpr int P = Model::kParams;
  double last_step = std::numeric_limits<double>::infinity();
  int steps = 0;
  for (; steps < 10; ++steps) {
    std::vector<Eigen::Matrix<double, P, 1>> rows;
    std::vector<double> res;
    NormalEquations<P> probe;
    probe.rows = &rows, probe.residuals = &res;
    model.Linearize(state, &probe);
    Eigen::Matrix<double, Eigen::Dynamic, P> j(static_cast<Eigen::Index>(rows.size()), P);
    for (size_t i = 0; i < rows.size(); ++i)
      j.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
    const Eigen::VectorXd r =
        Eigen::Map<const Eigen::VectorXd>(res.data(), static_cast<Eigen::Index>(res.size()));
    const Eigen::Matrix<double, P, 1> delta = j.colPivHouseholderQr().solve(-r);
    const double step = model.StepLength(delta);
    if (!delta.allFinite() || !(step < 0.5 * last_step)) break;
    const auto candidate = model.Update(state, delta);
    auto candidate_ne = model.Linearize(candidate);
    if (!(candidate_ne.ss <= ne.ss * (1.0 + 1e-12) + 1e-300)) break;
    state = candidate;
    ne = candidate_ne;
    last_step = step;
    if (step <= 1e-13 * model.Scale()) break;
  }
  return steps;
}

// See SolveLm: a Gauss-Newton step this small relative to the data scale ends the iteration.
constexpr double kFinishedStep = 1e-9;

template <class Model>
LmSummary SolveLm(const Model& model,
                  typename Model::State& state,
                  int max_iterations,
                  NormalEquations<Model::kParams>* last = nullptr) {
  constexpr int P = Model::kParams;
  using VecP = Eigen::Matrix<double, P, 1>;
  // A step below this moves no parameter beyond double rounding of the data: stationary.
  const double converged_step_mm = 1e-12 * model.Scale();
  // Below this sum of squares [mm^2] the data fit exactly to double precision.
  const double kTinyCost = 1e-30 * model.Scale() * model.Scale();
  LmSummary summary;
  double lambda = 1e-6;
  auto ne = model.Linearize(state);
  for (int it = 0; it < max_iterations; ++it) {
    summary.iterations = it + 1;
    ne.Finish();
    Eigen::Matrix<double, P, P> damped = ne.jtj;
    damped.diagonal() += lambda * ne.jtj.diagonal();
    const VecP delta = damped.ldlt().solve(-ne.jtr);
    if (!delta.allFinite()) break;
    // The undamped step estimates the distance to the optimum: once it is below 1e-9 of the data
    // scale (1 nm on 1000 mm) the current state, whose linearisation we already hold, is the
    // answer; evaluating the step would cost a pass over the points for nothing measurable.
    // The test uses the undamped step: damping shrinks it along weak directions of
    // ill-conditioned data (narrow sectors) by orders of magnitude.
    const VecP gn_step = ne.jtj.ldlt().solve(-ne.jtr);
    if (gn_step.allFinite() && model.StepLength(gn_step) <= kFinishedStep * model.Scale()) {
      summary.converged = true;
      break;
    }
    // Stationary once the step moves no parameter beyond rounding, or once the Gauss-Newton
    // model predicts no decrease of the sum of squares beyond rounding (then polished below).
    const double predicted = -(2.0 * delta.dot(ne.jtr) + delta.dot(ne.jtj * delta));
    const bool stationary =
        model.StepLength(delta) <= converged_step_mm || predicted <= 1e-15 * ne.ss + kTinyCost;
    const auto candidate = model.Update(state, delta);
    // Linearising at the candidate also yields its cost: one pass over the points per step.
    auto candidate_ne = model.Linearize(candidate);
    if (candidate_ne.ss <= ne.ss) {
      state = candidate;
      ne = candidate_ne;
      lambda = std::max(lambda * 0.1, 1e-15);
    } else if (!stationary) {
      lambda *= 10.0;
      if (lambda > 1e16) break;
      continue;
    }
    if (stationary) {
      summary.converged = true;
      break;
    }
  }
  if (summary.converged && model.Size() <= kQrPolishPoints && IsIllConditioned(ne, model)) {
    summary.iterations += PolishByQr(model, state, ne);
  }
  ne.Finish();
  summary.ss = ne.ss;
  if (last != nullptr) *last = ne;
  return summary;
}

// Points used to converge before the full cloud is touched: the subsample's solution lies within
// noise / sqrt(kCoarsePoints) of the full one, so the full cloud needs only 2-3 Gauss-Newton steps.
constexpr Eigen::Index kCoarsePoints = 5000;

// Residual statistics from the final linearisation (saves a pass over the points).
template <int P>
FitStats StatsFrom(const NormalEquations<P>& ne, Eigen::Index n, int iterations) {
  FitStats s;
  s.n = static_cast<int>(n);
  s.rms = std::sqrt(ne.ss / static_cast<double>(n));
  s.min_residual = ne.min_r;
  s.max_residual = ne.max_r;
  s.iterations = iterations;
  return s;
}

// Covariance sigma^2 (J^T J)^-1 with sigma^2 = ss / (m - p); zero when there is no redundancy.
// The inverse is taken of J^T J scaled to a unit diagonal (Jacobi), then scaled back: on a
// short arc far from the origin the parameters' columns differ by orders of magnitude (a tilt
// in rad on a lever of 1000 mm beside a centre in mm), and the unscaled pseudo-inverse lost the
// small variances to the large ones' rounding (issue 49).
template <int P>
Eigen::MatrixXd CovarianceFrom(NormalEquations<P> ne, int residual_count) {
  ne.Finish();
  const int dof = residual_count - P;
  const double sigma2 = dof > 0 ? ne.ss / dof : 0.0;
  const Eigen::Matrix<double, P, 1> d =
      ne.jtj.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::Matrix<double, P, P> scaled = d.asDiagonal() * ne.jtj * d.asDiagonal();
  const Eigen::MatrixXd inv = scaled.completeOrthogonalDecomposition().pseudoInverse();
  return sigma2 * (d.asDiagonal() * inv * d.asDiagonal());
}

// True when the normal matrix is numerically singular: the points do not determine every
// parameter (e.g. a cylinder through points on one circle). Columns are scaled by physical
// units rather than by their own norm, which would blow a rounding-level column back up to
// full size and hide the degeneracy: 1 for lengths in mm, 1 / the data scale for angles in rad
// (an angle in mm is the angle times its lever arm). These were the data scale itself until
// issue 49, which put a tilt's column scale^2 above a length's and refused every arc of a
// 1000 mm circle up to 45 deg as "not separable".
template <int P>
bool IsRankDeficient(NormalEquations<P> ne, const Eigen::Matrix<double, P, 1>& units) {
  ne.Finish();
  const Eigen::Matrix<double, P, P> scaled = units.asDiagonal() * ne.jtj * units.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, P, P>> es(scaled, Eigen::EigenvaluesOnly);
  // Condition number of the unit-scaled Jacobian above 1e7: parameters not determined. The
  // hardest well-posed data (10 deg arcs, 15 deg caps and sectors) stay below 1e5.
  return !(es.eigenvalues()(0) > 1e-14 * es.eigenvalues()(P - 1));
}

template <int P>
bool IsRankDeficient(const NormalEquations<P>& ne) {
  return IsRankDeficient(ne, Eigen::Matrix<double, P, 1>::Ones().eval());
}

}  // namespace mlp::geometry::internal
