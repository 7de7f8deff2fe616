#pragma once
// Levenberg-Marquardt for small fixed-size parameter vectors and many residuals.
//
// Why not Ceres: a fit of 1e6 points with <= 6 parameters is dominated by per-residual
// overhead in a general solver; here each iteration is one pass that accumulates the P x P
// normal equations J^T J and J^T r directly (cache-friendly, no Jacobian storage), and the model
// re-linearises in a local frame each iteration (Forbes' scheme), which Ceres manifolds would
// only approximate. Ceres stays the tool for the calibration problems.

#include "mlp/geometry/error.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace mlp::geometry::internal {

template <int P>
struct NormalEquations {
  Eigen::Matrix<double, P, P> jtj = Eigen::Matrix<double, P, P>::Zero();
  Eigen::Matrix<double, P, 1> jtr = Eigen::Matrix<double, P, 1>::Zero();
  double ss = 0.0;  // sum of squared residuals

  void Add(const Eigen::Matrix<double, P, 1>& j, double r) {
    jtj.template selfadjointView<Eigen::Lower>().rankUpdate(j);
    jtr += j * r;
    ss += r * r;
  }
  void Finish() { jtj = jtj.template selfadjointView<Eigen::Lower>(); }
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
// Pure Gauss-Newton steps from a point where the cost is flat to rounding: accepted while the
// cost stays within rounding of the best and the step keeps shrinking. On ill-conditioned data
// (narrow sectors) this moves the parameters from "cost flat" to "gradient zero", which can be
// 1e-7 rad apart on a 15 deg cone sector.
template <class Model>
int PolishGaussNewton(const Model& model,
                      typename Model::State& state,
                      internal::NormalEquations<Model::kParams>& ne) {
  constexpr int P = Model::kParams;
  double last_step = std::numeric_limits<double>::infinity();
  int steps = 0;
  for (; steps < 20; ++steps) {
    ne.Finish();
    const Eigen::Matrix<double, P, 1> delta = ne.jtj.ldlt().solve(-ne.jtr);
    const double step = model.StepLength(delta);
    if (!delta.allFinite() || !(step < 0.5 * last_step)) break;
    const auto candidate = model.Update(state, delta);
    auto candidate_ne = model.Linearize(candidate);
    if (!(candidate_ne.ss <= ne.ss * (1.0 + 1e-12) + 1e-300)) break;
    state = candidate;
    ne = candidate_ne;
    last_step = step;
    if (step <= 1e-15 * model.Scale()) break;
  }
  return steps;
}

template <class Model>
LmSummary SolveLm(const Model& model, typename Model::State& state, int max_iterations) {
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
      summary.iterations += PolishGaussNewton(model, state, ne);
      break;
    }
  }
  ne.Finish();
  summary.ss = ne.ss;
  return summary;
}

// Covariance sigma^2 (J^T J)^-1 with sigma^2 = ss / (m - p); zero when there is no redundancy.
template <int P>
Eigen::MatrixXd CovarianceFrom(NormalEquations<P> ne, int residual_count) {
  ne.Finish();
  const int dof = residual_count - P;
  const double sigma2 = dof > 0 ? ne.ss / dof : 0.0;
  Eigen::MatrixXd inv = ne.jtj.completeOrthogonalDecomposition().pseudoInverse();
  return sigma2 * inv;
}

// True when the scaled normal matrix is numerically singular: the points do not determine
// every parameter (e.g. a cylinder through points on one circle).
template <int P>
bool IsRankDeficient(NormalEquations<P> ne) {
  ne.Finish();
  const Eigen::Matrix<double, P, 1> d =
      ne.jtj.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::Matrix<double, P, P> scaled = d.asDiagonal() * ne.jtj * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, P, P>> es(scaled, Eigen::EigenvaluesOnly);
  // Condition number of the scaled Jacobian above ~1e10: parameters not determined.
  return !(es.eigenvalues()(0) > 1e-20 * es.eigenvalues()(P - 1)) ||
         ne.jtj.diagonal().minCoeff() <= 0.0;
}

}  // namespace mlp::geometry::internal
