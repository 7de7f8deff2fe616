// Least-squares circle (2D), sphere and circle in 3D (plane first, then circle: NIST; the
// ISO 10360-6 spatial circle refines it, fit_circle_space.cc).
// Start: the algebraic fit of Kasa (IEEE Trans. Instrum. Meas. 25 (1976) 8); then
// Levenberg-Marquardt on the geometric residual |p - c| - r, which is what ISO 10360-6 asks.

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <limits>
#include <optional>
#include <sstream>

#include "algebraic.h"
#include "circle_space.h"
#include "common.h"
#include "lm.h"

namespace mlp::geometry {
namespace {

using internal::NormalEquations;

template <int N>
using PointsN = Eigen::Matrix<double, N, Eigen::Dynamic>;

// Circle (N = 2) or sphere (N = 3) model; state = (centre, radius) relative to `origin`.
// A circle model can also read 3D points and project them on the fly onto a plane (basis rows
// u, v through origin3): the circle in 3D then needs no projected copy of the whole cloud.
template <int N>
class NSphereModel {
 public:
  static constexpr int kParams = N + 1;
  using State = Eigen::Matrix<double, N + 1, 1>;

  NSphereModel(const PointsN<N>& points, const Eigen::Matrix<double, N, 1>& origin, double scale)
      : points_(points.data()), size_(points.cols()), origin_(origin), scale_(scale) {}
  // Projected circle: in-plane coordinates basis * (p - origin3); the state is relative to them.
  NSphereModel(const Points3& points3,
               const Eigen::Matrix<double, 2, 3>& basis,
               const Vec3& origin3,
               double scale) requires(N == 2)
      : points_(points3.data()),
        size_(points3.cols()),
        origin_(Vec2::Zero()),
        scale_(scale),
        projected_(true),
        basis_(basis),
        origin3_(origin3) {}

  MLP_DISPATCH NormalEquations<kParams> Linearize(const State& s,
                                                  NormalEquations<kParams>* sink = nullptr) const {
    internal::Accumulator<kParams> ne(sink);
    double c[N];
    for (int k = 0; k < N; ++k) c[k] = s(k) + origin_(k);
    const double radius = s(N);
    if constexpr (N == 2) {
      if (projected_) {
        LinearizeProjected(c, radius, &ne);
        return ne.Finish(sink);
      }
    }
    const double* p = points_;
    ne.AddRows(size_, [&](Eigen::Index first, int m, internal::RowChunk<kParams>& chunk) {
      const double* q = p + N * first;
      // int i: m is one chunk's row count (internal::kChunkRows), so N * i cannot overflow.
      // NOLINTBEGIN(bugprone-implicit-widening-of-multiplication-result)
#pragma omp simd
      for (int i = 0; i < m; ++i) {
        // Written out per dimension: an inner loop here stops GCC vectorising the outer one.
        double d[N];
        d[0] = q[N * i] - c[0];
        d[1] = q[N * i + 1] - c[1];
        double d2 = d[0] * d[0] + d[1] * d[1];
        if constexpr (N == 3) d[2] = q[N * i + 2] - c[2], d2 += d[2] * d[2];
        Row(d, d2, radius, i, chunk);
      }
      // NOLINTEND(bugprone-implicit-widening-of-multiplication-result)
    });
    return ne.Finish(sink);
  }
  State Update(const State& s, const State& delta) const { return s + delta; }
  double StepLength(const State& delta) const { return delta.norm(); }
  double Scale() const { return scale_; }
  Eigen::Index Size() const { return size_; }

 private:
  // Jacobian row and residual of one point at offset d from the centre (|d|^2 = d2). A point
  // exactly at the centre has no radial direction (d = 0 gives a zero row: it only informs the
  // radius). Branch-free, so that the loop vectorises.
  [[gnu::always_inline]] static void Row(
      const double (&d)[N], double d2, double radius, int i, internal::RowChunk<kParams>& chunk) {
    const double dist = std::sqrt(d2);
    const double inv = 1.0 / std::max(dist, std::numeric_limits<double>::min());
    chunk.j[0][i] = -d[0] * inv;
    chunk.j[1][i] = -d[1] * inv;
    if constexpr (N == 3) chunk.j[2][i] = -d[2] * inv;
    chunk.j[N][i] = -1.0;
    chunk.r[i] = dist - radius;
  }

  [[gnu::always_inline]] void LinearizeProjected(const double (&c)[N],
                                                 double radius,
                                                 internal::Accumulator<kParams>* ne) const {
    const double* p = points_;
    double b[2][3], o[3];
    for (int k = 0; k < 3; ++k) b[0][k] = basis_(0, k), b[1][k] = basis_(1, k), o[k] = origin3_(k);
    ne->AddRows(size_, [&](Eigen::Index first, int m, internal::RowChunk<kParams>& chunk) {
      const double* q = p + 3 * first;
      // int i, as in Linearize: 3 * i < 3 * kChunkRows.
      // NOLINTBEGIN(bugprone-implicit-widening-of-multiplication-result)
#pragma omp simd
      for (int i = 0; i < m; ++i) {
        const double x = q[3 * i] - o[0], y = q[3 * i + 1] - o[1], z = q[3 * i + 2] - o[2];
        double d[N];
        d[0] = b[0][0] * x + b[0][1] * y + b[0][2] * z - c[0];
        d[1] = b[1][0] * x + b[1][1] * y + b[1][2] * z - c[1];
        Row(d, d[0] * d[0] + d[1] * d[1], radius, i, chunk);
      }
      // NOLINTEND(bugprone-implicit-widening-of-multiplication-result)
    });
  }

  const double* points_;  // N x size (or 3 x size when projected), column-major
  Eigen::Index size_;
  Eigen::Matrix<double, N, 1> origin_;
  double scale_;
  bool projected_ = false;
  Eigen::Matrix<double, 2, 3> basis_ = Eigen::Matrix<double, 2, 3>::Zero();
  Vec3 origin3_ = Vec3::Zero();
};

// Kasa's circle/sphere as a state relative to `centroid`; empty when it has no solution.
template <int N>
std::optional<Eigen::Matrix<double, N + 1, 1>> KasaStart(
    const PointsN<N>& points, const Eigen::Matrix<double, N, 1>& centroid) {
  Eigen::Matrix<double, N, 1> center;
  double radius = 0.0;
  bool ok = false;
  if constexpr (N == 2) {
    ok = internal::KasaCircle(points, centroid, &center, &radius);
  } else {
    ok = internal::KasaSphere(points, centroid, &center, &radius);
  }
  if (!ok) return std::nullopt;
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

// Least-squares circle/sphere in the coordinates of `m` (moments of all points): converged on
// `coarse` (a subsample, or every point), then finished on every point by `full` when given.
template <int N>
NSphereSolution SolveNSphere(const NSphereModel<N>& coarse_model,
                             std::optional<Eigen::Matrix<double, N + 1, 1>> start,
                             const internal::Moments<N>& m,
                             Eigen::Index count,
                             const NSphereModel<N>* full,
                             const FitOptions& options,
                             const char* shape) {
  const auto ev = internal::SortedEigen<N>(m.scatter).eigenvalues();
  // Points in a subspace (collinear for a circle, coplanar for a sphere) fit a family of shapes.
  if (!(ev(0) > 1e-14 * ev(N - 1))) {
    internal::ThrowDegenerate(shape,
                              N == 2 ? "the points are collinear" : "the points are coplanar");
  }
  if (!start) internal::ThrowDegenerate(shape, "no algebraic start");
  const double scale = internal::DataScale<N>(m, count);
  auto state = *start;
  internal::NormalEquations<N + 1> ne;
  auto summary = internal::SolveLm(coarse_model, state, options.max_iterations, &ne);
  if (!summary.converged || !state.allFinite() || !(state(N) > 0.0)) {
    // Kasa's start fails on shallow arcs and caps whose form deviation exceeds their sagitta.
    // Fall back to circles/spheres tangent to the least-squares line/plane at the centroid, on
    // both sides and at several radii, and keep the best stationary point.
    summary = SolveFromTangentStarts<N>(coarse_model, m, scale, options.max_iterations, &state);
    ne = coarse_model.Linearize(state);
  }
  if (full != nullptr) {
    const int coarse_iterations = summary.iterations;
    summary = internal::SolveLm(*full, state, options.max_iterations, &ne);
    summary.iterations += coarse_iterations;
  }
  if (!state.allFinite() || !(state(N) > 0.0) ||
      (!summary.converged && options.require_convergence)) {
    internal::ThrowNotConverged(shape, summary.iterations);
  }
  if (internal::IsRankDeficient(ne)) internal::ThrowDegenerate(shape, "parameters not separable");
  NSphereSolution sol;
  sol.center = state.template head<N>() + m.centroid;
  sol.radius = state(N);
  sol.stats = internal::StatsFrom(ne, count, summary.iterations);
  sol.stats.converged = summary.converged;
  sol.covariance = internal::CovarianceFrom(ne, static_cast<int>(count));
  return sol;
}

template <int N>
NSphereSolution FitNSphere(const PointsN<N>& points, const FitOptions& options, const char* shape) {
  options.Check();
  internal::CheckPoints(points, N + 1, shape, false);
  const auto m = internal::ComputeMoments<N>(points);
  // Start and converge on a subsample, then finish on every point.
  PointsN<N> storage;
  const PointsN<N>& coarse = internal::SubsampleView<N>(points, internal::kCoarsePoints, &storage);
  const double scale = internal::DataScale<N>(m, points.cols());
  const NSphereModel<N> full(points, m.centroid, scale);
  const NSphereModel<N> coarse_model(coarse, m.centroid, scale);
  return SolveNSphere<N>(coarse_model, KasaStart<N>(coarse, m.centroid), m, points.cols(),
                         coarse.cols() < points.cols() ? &full : nullptr, options, shape);
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

Vec3 SphereCentreWithRadius(const Points3& points, double radius, const Vec3& start) {
  constexpr int kMaxSteps = 50;
  Vec3 c = start;
  for (int step = 0; step < kMaxSteps; ++step) {
    Eigen::Matrix3d jtj = Eigen::Matrix3d::Zero();
    Vec3 jtr = Vec3::Zero();
    for (Eigen::Index k = 0; k < points.cols(); ++k) {
      const Vec3 d = points.col(k) - c;
      const double n = d.norm();
      if (!(n > 0)) continue;
      const Vec3 row = -d / n;  // d r / d c
      jtj += row * row.transpose(), jtr += row * (n - radius);
    }
    const Vec3 dc = jtj.ldlt().solve(-jtr);
    if (!dc.allFinite()) break;
    c += dc;
    if (dc.norm() < 1e-9) break;
  }
  return c;
}

FitResult<Sphere> FitSphere(const Points3& points, const FitOptions& options) {
  const auto sol = FitNSphere<3>(points, options, "sphere");
  FitResult<Sphere> fit;
  fit.shape.center = sol.center;
  fit.shape.radius = sol.radius;
  fit.stats = sol.stats;
  fit.covariance.parameters = {"center_x", "center_y", "center_z", "radius"};
  fit.covariance.matrix = sol.covariance;
  internal::RequireDetermined("sphere", fit.covariance,
                              {"radius", "center_x", "center_y", "center_z"}, fit.shape.radius,
                              options.max_relative_std_dev);
  return fit;
}

namespace {

// The centre's height over the plane as a parameter of its own ("center_w", as the spatial
// circle reports it): the plane's offset is at the centroid, and a circle seen on a short arc
// has its centre a radius away, where the plane's tilt moves it. With the plane through the
// centroid c0 + offset n, tilted to n + tilt_u u + tilt_v v, the height at (x, y) in plane
// coordinates is offset - x tilt_u - y tilt_v: propagated to the centre (x, y) = `center_uv`.
void AppendCenterHeight(const Vec2& center_uv, Covariance* c) {
  const Eigen::Index p = c->matrix.rows();
  Eigen::MatrixXd jacobian = Eigen::MatrixXd::Identity(p + 1, p);
  jacobian.row(p).setZero();
  jacobian(p, 0) = 1.0;  // offset, tilt_u, tilt_v lead the two-stage covariance
  jacobian(p, 1) = -center_uv.x();
  jacobian(p, 2) = -center_uv.y();
  c->matrix = jacobian * c->matrix * jacobian.transpose();
  c->parameters.push_back("center_w");
}

// The plane of the points must stand clear of their noise: an arc whose spread across its
// chord (its sagitta's share) is not well above its scatter off the plane leaves the plane
// free to turn about the chord, and the plane's linearised covariance then understates it
// (issue 49's sweep: 4 deg of R 4.4 mm, a 3 um sagitta in 2 um noise, tilted 0.12 rad where
// it reported 0.012). Measured as the standard deviations across the line of the points and
// off their plane; below kPlaneOverNoise the plane-then-circle circle is not determined.
constexpr double kPlaneOverNoise = 5.0;

void RequirePlaneOfArc(const Points3& points) {
  const Vec3 ev =
      internal::SortedEigen<3>(internal::ComputeMoments<3>(points).scatter).eigenvalues();
  const double across = std::sqrt(std::max(0.0, ev(1) / static_cast<double>(points.cols())));
  const double off = std::sqrt(std::max(0.0, ev(0) / static_cast<double>(points.cols())));
  if (across >= kPlaneOverNoise * off) return;
  std::ostringstream why;
  why.precision(3);
  why << "circle: not determined: the points stand " << across * 1e3
      << " um across their line against " << off * 1e3 << " um off their plane, under "
      << kPlaneOverNoise
      << " times: the circle's plane, and so its standard deviation, is not found (a longer arc)";
  throw GeometryError(ErrorCode::kDegenerate, why.str());
}

// The plane first, then the circle in plane coordinates (u, v through the centroid); the
// circle model projects the points on the fly, so no projected copy of the cloud is made.
FitResult<Circle3> FitCircle3PlaneFirst(const Points3& points, const FitOptions& options) {
  internal::CheckPoints(points, 3, "circle", false);
  const auto m3 = internal::ComputeMoments<3>(points);
  const auto plane = internal::PlaneFromMoments(m3, points.cols());
  const Vec3 u = plane.covariance.u;
  const Vec3 v = plane.covariance.v;
  Eigen::Matrix<double, 2, 3> basis;
  basis.row(0) = u.transpose();
  basis.row(1) = v.transpose();
  internal::Moments<2> m2;  // in plane coordinates: the centroid is their origin
  m2.centroid = Vec2::Zero();
  m2.scatter = basis * m3.scatter * basis.transpose();
  Points3 storage;
  const Points3& coarse3 = internal::SubsampleView<3>(points, internal::kCoarsePoints, &storage);
  const double scale = internal::DataScale<2>(m2, points.cols());
  const NSphereModel<2> coarse_model(coarse3, basis, m3.centroid, scale);
  const NSphereModel<2> full(points, basis, m3.centroid, scale);
  // Kasa's circle of the coarse points, projected on the fly (no projected copy).
  Vec2 kasa_center;
  double kasa_radius = 0.0;
  std::optional<Vec3> start;
  if (internal::KasaCircleInPlane(coarse3, basis, m3.centroid, &kasa_center, &kasa_radius)) {
    start = Vec3(kasa_center(0), kasa_center(1), kasa_radius);
  }
  const auto sol =
      SolveNSphere<2>(coarse_model, start, m2, points.cols(),
                      coarse3.cols() < points.cols() ? &full : nullptr, options, "circle");
  FitResult<Circle3> fit;
  fit.shape.center = m3.centroid + u * sol.center(0) + v * sol.center(1);
  fit.shape.normal = plane.shape.normal;
  fit.shape.radius = sol.radius;
  fit.stats = sol.stats;
  Covariance in_plane;
  in_plane.parameters = {"center_x", "center_y", "radius"};
  in_plane.matrix = sol.covariance;
  fit.covariance = internal::TwoStageCovariance(plane, in_plane, {"center_u", "center_v"});
  AppendCenterHeight(sol.center, &fit.covariance);
  return fit;
}

}  // namespace

FitResult<Circle3> FitCircle3(const Points3& points, const FitOptions& options) {
  options.Check();
  // Either definition: an arc too flat for its noise has no plane to find.
  if (std::isfinite(options.max_relative_std_dev) && points.cols() >= 3) RequirePlaneOfArc(points);
  if (options.circle3 == Circle3Definition::kPlaneThenCircle) {
    auto fit = FitCircle3PlaneFirst(points, options);
    internal::RequireDetermined("circle", fit.covariance,
                                {"radius", "center_u", "center_v", "center_w"}, fit.shape.radius,
                                options.max_relative_std_dev);
    return fit;
  }
  // The spatial circle starts from the plane-then-circle one; that start may stop short of
  // convergence (the refinement decides), but not on a shape that is no circle.
  FitOptions start = options;
  start.require_convergence = false;
  return internal::RefineCircle3InSpace(points, FitCircle3PlaneFirst(points, start), options);
}

}  // namespace mlp::geometry
