// The circle in space as ISO 10360-6 defines it (and PTB's TraCIM Gaussian test checks it): the
// circle minimising the sum of squared orthogonal distances in space. The distance of a point to
// the circle is d = hypot(h, rho - r), h its height over the circle's plane and rho its distance
// from the circle's axis; two residuals per point, h and rho - r, have exactly that sum of
// squares and, unlike d, are smooth where a point lies on the circle.
//
// Solved by variable projection (Golub & Pereyra, SIAM J. Numer. Anal. 10 (1973) 413): for a
// given normal n, the best circle is exact and cheap (its height is the mean height, its centre
// and radius the 2D least-squares circle of the points projected on the plane), so only the
// normal's two tilts are iterated, by Newton's method on the reduced sum of squares f(n), from
// the plane-then-circle fit. Why not Levenberg-Marquardt on all six parameters, as the other
// fits: on narrow arcs with out-of-plane form its path follows a curved valley (the centre must
// swing with the tilt on a lever of one radius) and it took over 200 iterations, still 4e-7 rad
// from the optimum, on a 15 deg arc; with the centre and radius projected out, Newton converges
// there in a few steps.

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "circle_space.h"
#include "common.h"
#include "lm.h"

namespace mlp::geometry::internal {
namespace {

using Step6 = Eigen::Matrix<double, 6, 1>;

struct CircleState {
  Vec3 center;  // relative to the model's origin
  Vec3 normal;  // unit
  double radius = 0.0;
};

// h H(h) + (rho - r) H(rho) of one point, at the step's origin. With the step
// (d0, d1, d2, a, b, dr): c' = c + d0 u + d1 v + d2 n, n' = (n + a u + b v) / |...|, so
// h = (q - dc).n' = z - d2 + a x + b y - a d0 - b d1 - (a^2 + b^2) z / 2 + O(3), and
// rho^2 = g = |q - dc|^2 - h^2, whose Hessian is 2 I (centre) - 2 grad h grad h^T - 2 h H(h);
// H(rho) = H(g) / (2 rho) - grad rho grad rho^T / rho.
Eigen::Matrix<double, 6, 6> SecondOrder(double h,
                                        double rho,
                                        double inv_rho,
                                        const Step6& grad_h,
                                        const Step6& grad_rho,
                                        double radius) {
  Eigen::Matrix<double, 6, 6> hess_h = Eigen::Matrix<double, 6, 6>::Zero();
  hess_h(3, 3) = hess_h(4, 4) = -h;
  hess_h(0, 3) = hess_h(3, 0) = hess_h(1, 4) = hess_h(4, 1) = -1.0;
  Eigen::Matrix<double, 6, 6> hess_g = -2.0 * grad_h * grad_h.transpose() - 2.0 * h * hess_h;
  hess_g.diagonal().head<3>().array() += 2.0;
  const Eigen::Matrix<double, 6, 6> hess_rho =
      0.5 * inv_rho * hess_g - inv_rho * grad_rho * grad_rho.transpose();
  return h * hess_h + (rho - radius) * hess_rho;
}

// Gradient and Hessian of the sum of squares at a circle, in the parameters of a step in the
// frame (u, v, n) of that circle: the centre's offset along u, v, n [mm]; the normal's tilt
// towards u and v [rad]; the radius [mm]. `ne` holds J^T J (Gauss-Newton) and J^T r;
// `second_order` the residuals' sum r H(r), which makes J^T J + it the exact Hessian (computed
// only when asked: one pass gives both).
struct CircleLinearization {
  NormalEquations<6> ne;
  Eigen::Matrix<double, 6, 6> second_order = Eigen::Matrix<double, 6, 6>::Zero();
};

CircleLinearization Linearize(const Points3& points,
                              const Vec3& origin,
                              const CircleState& s,
                              bool with_second_order) {
  Vec3 u, v;
  OrthonormalBasis(s.normal, &u, &v);
  Accumulator<6> acc(nullptr);
  CircleLinearization out;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Vec3 q = points.col(i) - origin - s.center;
    const double x = q.dot(u), y = q.dot(v), h = q.dot(s.normal);
    const double rho = std::hypot(x, y);
    // A point on the axis has no radial direction: its rho - r row informs the radius only.
    const double inv = 1.0 / std::max(rho, std::numeric_limits<double>::min());
    const Step6 grad_h = (Step6() << 0.0, 0.0, -1.0, x, y, 0.0).finished();
    const Step6 grad_rho =
        (Step6() << -x * inv, -y * inv, 0.0, -h * x * inv, -h * y * inv, 0.0).finished();
    acc.Add(grad_h, h);
    acc.Add(grad_rho - Step6::Unit(5), rho - s.radius);
    if (with_second_order && rho > 0.0)
      out.second_order += SecondOrder(h, rho, inv, grad_h, grad_rho, s.radius);
  }
  out.ne = acc.Finish(nullptr);
  out.ne.Finish();
  return out;
}

// The best circle for a given normal: height = mean height, centre and radius = the 2D
// least-squares circle of the points in the plane's (u, v). `ss` is the spatial sum of squares.
struct ProjectedCircle {
  CircleState state;  // centre relative to the origin
  double ss = INFINITY;
  bool ok = false;  // false: no circle for this normal (the projected points are collinear)
};

ProjectedCircle BestCircleFor(const Points3& points, const Vec3& origin, const Vec3& normal) {
  Vec3 u, v;
  OrthonormalBasis(normal, &u, &v);
  const Points3 local = ToFrame(points, origin, u, v, normal);
  const double height = local.row(2).mean();
  ProjectedCircle best;
  FitOptions inner;
  inner.require_convergence = false;
  try {
    const auto circle = FitCircle2(local.topRows<2>(), inner);
    best.state = {circle.shape.center.x() * u + circle.shape.center.y() * v + height * normal,
                  normal, circle.shape.radius};
    const double ss_circle = circle.stats.rms * circle.stats.rms * circle.stats.n;
    best.ss = (local.row(2).array() - height).square().sum() + ss_circle;
    best.ok = std::isfinite(best.ss);
  } catch (const GeometryError&) {
    best.ok = false;
  }
  return best;
}

// The step on the two tilts of the reduced sum of squares f(n) = min over centre and radius,
// with `hessian` the full one: at the inner optimum the gradient is the tilts' part of J^T r
// (the others vanish) and the reduced Hessian is the Schur complement onto the tilts (implicit
// function theorem). Empty when that is not positive definite.
std::optional<Eigen::Vector2d> ReducedStep(const Eigen::Matrix<double, 6, 6>& hessian,
                                           const Step6& jtr) {
  const std::array<int, 4> shape_idx{0, 1, 2, 5};
  const std::array<int, 2> tilt_idx{3, 4};
  Eigen::Matrix4d h_ss;
  Eigen::Matrix<double, 4, 2> h_st;
  Eigen::Matrix2d h_tt;
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) h_ss(i, j) = hessian(shape_idx[i], shape_idx[j]);
    for (int j = 0; j < 2; ++j) h_st(i, j) = hessian(shape_idx[i], tilt_idx[j]);
  }
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) h_tt(i, j) = hessian(tilt_idx[i], tilt_idx[j]);
  const Eigen::Matrix2d reduced = h_tt - h_st.transpose() * h_ss.ldlt().solve(h_st);
  const Eigen::LLT<Eigen::Matrix2d> llt(reduced);
  if (llt.info() != Eigen::Success) return std::nullopt;
  Eigen::Vector2d step = llt.solve(-Eigen::Vector2d(jtr(3), jtr(4)));
  if (!step.allFinite()) return std::nullopt;
  return step;
}

// A tilt step under this [rad] moves no point beyond rounding: stationary.
constexpr double kStationaryTiltRad = 1e-12;
// A decrease of the sum of squares below this share of it is rounding, not progress (the sum
// is accumulated over up to 2e5 residuals in double precision).
constexpr double kRoundingOfSs = 1e-13;

// Newton's step (Gauss-Newton's where the Hessian is not positive definite: far from a
// minimum). The Gauss-Newton step comes first, from a cheap pass: when it is already below
// rounding the point is stationary and the second-order pass, the costly one (a 6 x 6 term per
// point), is not made. That is every fit of points close to one plane.
Eigen::Vector2d ReducedNewtonStep(const Points3& points, const Vec3& origin, const CircleState& s) {
  const CircleLinearization gn = Linearize(points, origin, s, false);
  const std::optional<Eigen::Vector2d> gn_step = ReducedStep(gn.ne.jtj, gn.ne.jtr);
  if (gn_step && gn_step->norm() <= kStationaryTiltRad) return *gn_step;
  const CircleLinearization lin = Linearize(points, origin, s, true);
  if (auto step = ReducedStep(lin.ne.jtj + lin.second_order, lin.ne.jtr)) return *step;
  return gn_step.value_or(Eigen::Vector2d::Zero());
}

Vec3 Tilted(const Vec3& normal, const Eigen::Vector2d& tilt) {
  Vec3 u, v;
  OrthonormalBasis(normal, &u, &v);
  return (normal + tilt.x() * u + tilt.y() * v).normalized();
}

// Signed 3D distance: the sign of rho - r (outside the circle's cylinder positive).
double SignedSpatialDistance(const Circle3& c, const Vec3& p) {
  const Vec3 q = p - c.center;
  const double h = q.dot(c.normal);
  const double rho_minus_r = (q - h * c.normal).norm() - c.radius;
  return std::copysign(std::hypot(h, rho_minus_r), rho_minus_r);
}

// Backtracking line search on f along Newton's tilt `step`, taken whole near the optimum; true
// when the iteration is done. Only a strict decrease moves; a decrease within rounding of f
// ends the iteration: on a short arc of a large circle (10 deg of R 250 mm) the tilt along the
// chord is weakly determined and Newton's steps there wandered at the level of f's rounding,
// taking equal values as progress until the iteration limit (issue 49: "no stationary point in
// 205 iterations"). No decrease along a descent direction: f is at rounding, done too.
bool LineSearch(const Points3& points,
                const Vec3& origin,
                const Eigen::Vector2d& step,
                ProjectedCircle* current) {
  for (double t = 1.0; t > 1e-6; t *= 0.5) {
    const ProjectedCircle trial =
        BestCircleFor(points, origin, Tilted(current->state.normal, t * step));
    if (trial.ok && trial.ss < current->ss) {
      const bool done = (t == 1.0 && step.norm() <= kFinishedStep) ||
                        current->ss - trial.ss <= kRoundingOfSs * current->ss;
      *current = trial;
      return done;
    }
  }
  return true;
}

}  // namespace

FitResult<Circle3> RefineCircle3InSpace(const Points3& points,
                                        const FitResult<Circle3>& in_plane,
                                        const FitOptions& options) {
  const Vec3 origin = in_plane.shape.center;
  const double scale = in_plane.shape.radius;
  ProjectedCircle current = BestCircleFor(points, origin, in_plane.shape.normal);
  if (!current.ok) ThrowDegenerate("circle", "no circle in the least-squares plane");
  bool converged = false;
  int iterations = 0;
  while (!converged && iterations < options.max_iterations) {
    ++iterations;
    const Eigen::Vector2d step = ReducedNewtonStep(points, origin, current.state);
    if (step.norm() <= kStationaryTiltRad) {
      converged = true;
      break;
    }
    converged = LineSearch(points, origin, step, &current);
  }
  const CircleState& state = current.state;
  const int total_iterations = in_plane.stats.iterations + iterations;
  if (!state.center.allFinite() || !(state.radius > 0.0))
    ThrowNotConverged("circle", total_iterations);
  // The rank test and the covariance take the Gauss-Newton matrix J^T J, as every other fit.
  const NormalEquations<6> ne = Linearize(points, origin, state, false).ne;
  // Every column in mm of residual per mm of parameter: a tilt of 1 rad moves a point by its
  // lever arm, the radius, so a tilt in mm is the angle times the radius and its column is
  // divided by it. (It was multiplied: on R 1000 mm the tilts' columns stood 1e6 above the
  // centre's and every arc up to 45 deg was called "not separable", issue 49.) This test is for
  // exact degeneracy only; how well the data determine the circle is its covariance's to say.
  const Step6 units = (Step6() << 1.0, 1.0, 1.0, 1.0 / scale, 1.0 / scale, 1.0).finished();
  if (IsRankDeficient(ne, units))
    ThrowNotSeparable("circle", std::isfinite(options.max_relative_std_dev));
  FitResult<Circle3> fit;
  fit.shape = Circle3{origin + state.center, CanonicalSign<Vec3>(state.normal), state.radius};
  fit.stats = ComputeStats(
      points.cols(),
      [&](Eigen::Index i) { return SignedSpatialDistance(fit.shape, points.col(i)); },
      total_iterations);
  fit.stats.converged = converged;
  fit.covariance.parameters = {"center_u", "center_v", "center_w", "tilt_u", "tilt_v", "radius"};
  fit.covariance.matrix = CovarianceFrom(ne, static_cast<int>(2 * points.cols()));
  // The frame of those parameters (the normal's sign as it was iterated).
  OrthonormalBasis(state.normal, &fit.covariance.u, &fit.covariance.v);
  // The data's say on determinacy comes before the solver's stop is judged (fit_ellipse.cc).
  RequireDetermined("circle", fit.covariance, {"radius", "center_u", "center_v", "center_w"},
                    fit.shape.radius, options.max_relative_std_dev);
  if (!converged && options.require_convergence) ThrowNotConverged("circle", total_iterations);
  return fit;
}

}  // namespace mlp::geometry::internal
