// Least-squares circle (2D), sphere and circle in 3D (plane first, then circle: ISO/NIST).
// Start: the algebraic fit of Kasa (IEEE Trans. Instrum. Meas. 25 (1976) 8); then
// Levenberg-Marquardt on the geometric residual |p - c| - r, which is what ISO 10360-6 asks.

#include "mlp/geometry/fit.h"

#include "algebraic.h"
#include "common.h"
#include "lm.h"

namespace mlp::geometry {
namespace {

using internal::NormalEquations;

template <int N>
using PointsN = Eigen::Matrix<double, N, Eigen::Dynamic>;

// Circle (N = 2) or sphere (N = 3) model; state = (centre, radius) in centred coordinates.
template <int N>
class NSphereModel {
 public:
  static constexpr int kParams = N + 1;
  using State = Eigen::Matrix<double, N + 1, 1>;

  // State is relative to `origin` (the centroid), so the points need no centred copy.
  NSphereModel(const PointsN<N>& points, const Eigen::Matrix<double, N, 1>& origin, double scale)
      : points_(points), origin_(origin), scale_(scale) {}

  NormalEquations<kParams> Linearize(const State& s,
                                     NormalEquations<kParams>* sink = nullptr) const {
    internal::Accumulator<kParams> ne(sink);
    const Eigen::Matrix<double, N, 1> c = s.template head<N>() + origin_;
    Eigen::Matrix<double, kParams, 1> j;
    j(N) = -1.0;
    for (Eigen::Index i = 0; i < points_.cols(); ++i) {
      const Eigen::Matrix<double, N, 1> d = points_.col(i) - c;
      const double dist = d.norm();
      // A point exactly at the centre has no radial direction; it only informs the radius.
      j.template head<N>() =
          dist > 0.0 ? Eigen::Matrix<double, N, 1>(-d / dist) : Eigen::Matrix<double, N, 1>::Zero();
      ne.Add(j, dist - s(N));
    }
    return ne.Finish(sink);
  }
  State Update(const State& s, const State& delta) const { return s + delta; }
  double StepLength(const State& delta) const { return delta.norm(); }
  double Scale() const { return scale_; }
  Eigen::Index Size() const { return points_.cols(); }

 private:
  const PointsN<N>& points_;
  Eigen::Matrix<double, N, 1> origin_;
  double scale_;
};

template <int N>
Eigen::Matrix<double, N + 1, 1> KasaStart(const PointsN<N>& centred, const char* shape) {
  Eigen::Matrix<double, N, 1> center;
  double radius = 0.0;
  bool ok = false;
  if constexpr (N == 2) {
    ok = internal::KasaCircle(centred, &center, &radius);
  } else {
    ok = internal::KasaSphere(centred, &center, &radius);
  }
  if (!ok) internal::ThrowDegenerate(shape, "no algebraic start");
  Eigen::Matrix<double, N + 1, 1> state;
  state << center, radius;
  return state;
}

template <int N>
internal::LmSummary SolveFromTangentStarts(const NSphereModel<N>& model,
                                           const internal::Moments<N>& m,
                                           double scale,
                                           int max_iterations,
                                           Eigen::Matrix<double, N + 1, 1>* best) {
  const Eigen::Matrix<double, N, 1> normal =
      internal::SortedEigen<N>(m.scatter).eigenvectors().col(0);
  internal::LmSummary best_summary;
  int total_iterations = 0;  // reported in the error if no start converges
  double best_ss = INFINITY;
  for (double radius_factor : {1.0, 3.0, 10.0, 30.0}) {
    for (double side : {-1.0, 1.0}) {
      Eigen::Matrix<double, N + 1, 1> s;
      s << side * radius_factor * scale * normal, radius_factor * scale;
      const auto summary = internal::SolveLm(model, s, max_iterations);
      total_iterations += summary.iterations;
      if (summary.converged && s.allFinite() && s(N) > 0.0 && summary.ss < best_ss) {
        best_ss = summary.ss, *best = s, best_summary = summary;
      }
    }
  }
  if (!best_summary.converged) best_summary.iterations = total_iterations;
  return best_summary;
}

struct NSphereSolution {
  Eigen::VectorXd center;
  double radius = 0.0;
  FitStats stats;
  Eigen::MatrixXd covariance;
};

template <int N>
NSphereSolution FitNSphere(const PointsN<N>& points, const FitOptions& options, const char* shape) {
  options.Check();
  internal::CheckPoints(points, N + 1, shape, false);
  const auto m = internal::ComputeMoments<N>(points);
  const auto ev = internal::SortedEigen<N>(m.scatter).eigenvalues();
  // Points in a subspace (collinear for a circle, coplanar for a sphere) fit a family of shapes.
  if (!(ev(0) > 1e-14 * ev(N - 1))) {
    internal::ThrowDegenerate(shape,
                              N == 2 ? "the points are collinear" : "the points are coplanar");
  }
  const double scale = internal::DataScale<N>(m, points.cols());
  // Start and converge on a subsample, then finish on every point.
  const PointsN<N> coarse = internal::Subsample<N>(points, internal::kCoarsePoints);
  const PointsN<N> coarse_centred = coarse.colwise() - m.centroid;
  auto state = KasaStart<N>(coarse_centred, shape);
  NSphereModel<N> coarse_model(coarse, m.centroid, scale);
  auto summary = internal::SolveLm(coarse_model, state, options.max_iterations);
  if (!summary.converged || !state.allFinite() || !(state(N) > 0.0)) {
    // Kasa's start fails on shallow arcs and caps whose form deviation exceeds their sagitta.
    // Fall back to circles/spheres tangent to the least-squares line/plane at the centroid, on
    // both sides and at several radii, and keep the best stationary point.
    summary = SolveFromTangentStarts<N>(coarse_model, m, scale, options.max_iterations, &state);
  }
  internal::NormalEquations<N + 1> ne;
  if (coarse.cols() < points.cols()) {
    NSphereModel<N> model(points, m.centroid, scale);
    const int coarse_iterations = summary.iterations;
    summary = internal::SolveLm(model, state, options.max_iterations, &ne);
    summary.iterations += coarse_iterations;
  } else {
    ne = coarse_model.Linearize(state);
  }
  if (!summary.converged || !state.allFinite() || !(state(N) > 0.0)) {
    internal::ThrowNotConverged(shape, summary.iterations);
  }
  if (internal::IsRankDeficient(ne)) internal::ThrowDegenerate(shape, "parameters not separable");
  const Eigen::Matrix<double, N, 1> center = state.template head<N>() + m.centroid;
  NSphereSolution sol;
  sol.center = center;
  sol.radius = state(N);
  sol.stats = internal::StatsFrom(ne, points.cols(), summary.iterations);
  sol.covariance = internal::CovarianceFrom(ne, static_cast<int>(points.cols()));
  return sol;
}

}  // namespace

FitResult<Circle2> FitCircle2(const Points2& points, const FitOptions& options) {
  const auto sol = FitNSphere<2>(points, options, "circle");
  FitResult<Circle2> fit;
  fit.shape.center = sol.center;
  fit.shape.radius = sol.radius;
  fit.stats = sol.stats;
  fit.covariance.parameters = {"center_x", "center_y", "radius"};
  fit.covariance.matrix = sol.covariance;
  return fit;
}

FitResult<Sphere> FitSphere(const Points3& points, const FitOptions& options) {
  const auto sol = FitNSphere<3>(points, options, "sphere");
  FitResult<Sphere> fit;
  fit.shape.center = sol.center;
  fit.shape.radius = sol.radius;
  fit.stats = sol.stats;
  fit.covariance.parameters = {"center_x", "center_y", "center_z", "radius"};
  fit.covariance.matrix = sol.covariance;
  return fit;
}

FitResult<Circle3> FitCircle3(const Points3& points, const FitOptions& options) {
  internal::CheckPoints(points, 3, "circle", false);
  const auto plane = internal::PlaneFromMoments(internal::ComputeMoments<3>(points), points.cols());
  const Vec3 u = plane.covariance.u;
  const Vec3 v = plane.covariance.v;
  const Points2 in_plane = internal::ProjectOnPlane(points, plane);
  const auto circle = FitCircle2(in_plane, options);
  FitResult<Circle3> fit;
  fit.shape.center = plane.shape.point + u * circle.shape.center.x() + v * circle.shape.center.y();
  fit.shape.normal = plane.shape.normal;
  fit.shape.radius = circle.shape.radius;
  fit.stats = circle.stats;
  fit.covariance = internal::TwoStageCovariance(plane, circle.covariance, {"center_u", "center_v"});
  return fit;
}

}  // namespace mlp::geometry
