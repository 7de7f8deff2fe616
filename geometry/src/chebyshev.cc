// Chebyshev fits by sequential linear programming from the least-squares solution: each LP is
// the exact Chebyshev problem linearised at the current estimate (Carr & Ferreira, Precision
// Engineering 17 (1995) 2; Anthony et al., NPL), solved by the small dual simplex in lp.h, inside
// a trust region that only shrinks when the true zone does not improve.

#include "mlp/geometry/chebyshev.h"

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <functional>
#include <numeric>
#include <random>

#include "common.h"
#include "lp.h"

namespace mlp::geometry {
namespace {

using internal::SolveSmallLp;

constexpr double kHuge = 1e9;  // bound for zone offsets/radii in scaled units: "unbounded"
constexpr int kRealignPasses = 8;

// Zone of y - slope . x over the points: {max, min}.
template <int K>
std::pair<double, double> Zone(const Eigen::Matrix<double, K, Eigen::Dynamic>& x,
                               const Eigen::VectorXd& y,
                               const Eigen::Matrix<double, K, 1>& slope) {
  const Eigen::VectorXd r = y - x.transpose() * slope;
  return {r.maxCoeff(), r.minCoeff()};
}

// Minimum vertical zone of heights y over coordinates x (K = 1 for lines, 2 for planes):
// variables (slope[K], top, bottom), minimise top - bottom. Exact LP, no linearisation.
template <int K>
Eigen::Matrix<double, K, 1> MinVerticalZone(const Eigen::Matrix<double, K, Eigen::Dynamic>& x,
                                            const Eigen::VectorXd& y) {
  const Eigen::Index n = y.size();
  Eigen::MatrixXd a(2 * n, K + 2);
  Eigen::VectorXd b(2 * n);
  a.setZero();
  a.topLeftCorner(n, K) = -x.transpose();
  a.col(K).head(n).setConstant(-1.0);  // y - s.x <= top
  b.head(n) = -y;
  a.bottomLeftCorner(n, K) = x.transpose();
  a.col(K + 1).tail(n).setConstant(1.0);  // y - s.x >= bottom
  b.tail(n) = y;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(K + 2);
  c(K) = 1.0, c(K + 1) = -1.0;
  Eigen::VectorXd bound = Eigen::VectorXd::Constant(K + 2, kHuge);
  bound.head(K).setConstant(1.0);  // slopes within 45 deg of the least-squares frame
  const auto lp = SolveSmallLp(c, a, b, bound);
  if (!lp.optimal) throw GeometryError(ErrorCode::kNotConverged, "minimum zone: LP did not solve");
  return lp.x.head(K);
}

template <class Shape>
FitStats StatsTo(const Shape& shape, const Points3& points) {
  return internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return SignedDistance(shape, points.col(i)); }, 0);
}

// Points in the frame (u, v, w) around `origin`.
struct Frame {
  Vec3 origin, u, v, w;
  Points3 Local(const Points3& p) const { return internal::ToFrame(p, origin, u, v, w); }
};

// In-plane coordinates of the points in their least-squares plane.
Frame CirclePlaneFrame(const Points3& points, Points2* in_plane) {
  const auto plane = FitPlane(points);
  Frame f{plane.shape.point, plane.covariance.u, plane.covariance.v, plane.shape.normal};
  *in_plane = f.Local(points).topRows<2>();
  return f;
}

// The same frame taken from a least-squares circle (its plane is the least-squares plane and
// its u, v are the plane's), centred on the circle: no second plane fit.
Frame CirclePlaneFrame(const FitResult<Circle3>& circle, const Points3& points, Points2* in_plane) {
  Frame f{circle.shape.center, circle.covariance.u, circle.covariance.v, circle.shape.normal};
  *in_plane = f.Local(points).topRows<2>();
  return f;
}

// The least-squares circle as the start of a Chebyshev circle: one that did not converge is
// still a start, and the fit says so (stats.converged) rather than giving no answer. Its plane
// is the least-squares plane of the points, where the zone is then found (chebyshev.h).
FitOptions RelaxedStart() {
  FitOptions o;
  o.require_convergence = false;
  o.circle3 = Circle3Definition::kPlaneThenCircle;
  return o;
}

double ZoneWidth(const Eigen::VectorXd& r) { return r.maxCoeff() - r.minCoeff(); }

// Radii from a centre.
template <int N>
Eigen::VectorXd Radii(const Eigen::Matrix<double, N, Eigen::Dynamic>& p,
                      const Eigen::Matrix<double, N, 1>& c) {
  return (p.colwise() - c).colwise().norm();
}

// Zone models for the sequential LP: a state, the radii of the points from it (distances from
// a centre or an axis), their gradient with respect to a step of D parameters, each in mm
// (so that one trust region bounds them all), and the state moved by a step.

// Circle (N = 2) or sphere (N = 3): the state is the centre, the step its offset.
template <int N>
struct CentreModel {
  static constexpr int kDim = N;
  using State = Eigen::Matrix<double, N, 1>;
  using Step = Eigen::Matrix<double, N, 1>;
  const Eigen::Matrix<double, N, Eigen::Dynamic>& p;

  Eigen::VectorXd Radii(const State& c) const { return geometry::Radii<N>(p, c); }
  Eigen::Matrix<double, Eigen::Dynamic, N> Gradient(const State& c) const {
    Eigen::Matrix<double, N, Eigen::Dynamic> dirs = p.colwise() - c;
    for (Eigen::Index i = 0; i < p.cols(); ++i) dirs.col(i) /= std::max(dirs.col(i).norm(), 1e-300);
    return -dirs.transpose();
  }
  State Update(const State& c, const Step& step) const { return c + step; }
};

// Cylinder: the state is the axis (a point, kept at the foot of the centroid, and a unit
// direction); the step moves the point across the axis (a, b along u, v) and tilts the axis so
// that the ends of the data move by (c, d) [mm] (tilt = c / half_length): Carr & Ferreira's
// linearisation of the distance to an axis.
struct AxisModel {
  static constexpr int kDim = 4;
  struct State {
    Vec3 point, axis;
  };
  using Step = Eigen::Vector4d;
  const Points3& p;
  Vec3 centroid;
  double half_length;  // of the data along the axis [mm]

  Points3 Local(const State& s) const {
    Vec3 u, v;
    internal::OrthonormalBasis(s.axis, &u, &v);
    return internal::ToFrame(p, s.point, u, v, s.axis);
  }
  Eigen::VectorXd Radii(const State& s) const {
    return Local(s).topRows<2>().colwise().norm().transpose();
  }
  Eigen::Matrix<double, Eigen::Dynamic, 4> Gradient(const State& s) const {
    const Points3 local = Local(s);
    Eigen::Matrix<double, Eigen::Dynamic, 4> g(p.cols(), 4);
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
      const double rho = std::max(local.col(i).head<2>().norm(), 1e-300);
      const double ux = local(0, i) / rho, uy = local(1, i) / rho, z = local(2, i) / half_length;
      g.row(i) << -ux, -uy, -ux * z, -uy * z;
    }
    return g;
  }
  State Update(const State& s, const Step& step) const {
    Vec3 u, v;
    internal::OrthonormalBasis(s.axis, &u, &v);
    const Vec3 axis = (s.axis + (step(2) * u + step(3) * v) / half_length).normalized();
    const Vec3 point = s.point + step(0) * u + step(1) * v;
    return {point + (centroid - point).dot(axis) * axis, axis};
  }
};

template <class Model>
struct SlpResult {
  typename Model::State state;
  /// The step fell to rounding or the trust region shrank to nothing: a stationary point. False:
  /// the iterations ran out, and `state` is the best iterate.
  bool converged = false;
};

// Sequential LP for zones of radii. `objective(radii)` is the true objective (to minimise);
// `solve_lp(radii, gradient, trust)` solves the linearised LP, whose first kDim variables are
// the step and whose others (radii) must not end on their bound ("unbounded").
template <class Model, class Objective, class SolveLp>
SlpResult<Model> SequentialLp(const Model& model,
                              typename Model::State state,
                              double scale,
                              const Objective& objective,
                              const SolveLp& solve_lp,
                              int max_iterations,
                              const char* what) {
  constexpr int kDim = Model::kDim;
  double trust = 0.1 * scale;
  double best = objective(model.Radii(state));
  for (int it = 0; it < max_iterations; ++it) {
    if (trust <= 1e-14 * scale) return {state, true};
    const auto lp = solve_lp(model.Radii(state), model.Gradient(state), trust);
    if (!lp.optimal)
      throw GeometryError(ErrorCode::kNotConverged, std::string(what) + ": LP failed");
    for (size_t k = kDim; k < lp.bound_active.size(); ++k) {
      if (lp.bound_active[k]) {
        throw GeometryError(ErrorCode::kUnbounded,
                            std::string(what) + ": the points do not enclose a centre");
      }
    }
    const typename Model::Step step = lp.x.template head<kDim>();
    const auto moved = model.Update(state, step);
    const double value = objective(model.Radii(moved));
    if (value < best) {
      state = moved, best = value;
      if (step.norm() < 0.5 * trust) trust = std::max(step.norm(), 1e-14 * scale);
    } else {
      trust *= 0.25;
    }
    if (step.norm() <= 1e-13 * scale) return {state, true};
  }
  return {state, trust <= 1e-14 * scale};
}

// Minimum zone: variables (step[D], outer, inner): inner <= r_i + g_i.step <= outer.
template <int D>
internal::LpResult ZoneLp(const Eigen::VectorXd& r,
                          const Eigen::Matrix<double, Eigen::Dynamic, D>& g,
                          double trust) {
  const Eigen::Index n = r.size();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n, D + 2);
  Eigen::VectorXd b(2 * n);
  a.topLeftCorner(n, D) = g;
  a.col(D).head(n).setConstant(-1.0);
  b.head(n) = -r;
  a.bottomLeftCorner(n, D) = -g;
  a.col(D + 1).tail(n).setConstant(1.0);
  b.tail(n) = r;
  Eigen::VectorXd c = Eigen::VectorXd::Zero(D + 2);
  c(D) = 1.0, c(D + 1) = -1.0;
  Eigen::VectorXd bound = Eigen::VectorXd::Constant(D + 2, kHuge);
  bound.head(D).setConstant(trust);
  return SolveSmallLp(c, a, b, bound);
}

// Maximum inscribed: maximise R with R <= r_i + g_i.step.
internal::LpResult InscribedLp(const Eigen::VectorXd& r,
                               const Eigen::Matrix<double, Eigen::Dynamic, 2>& g,
                               double trust) {
  const Eigen::Index n = r.size();
  Eigen::MatrixXd a(n, 3);
  a.leftCols(2) = -g;
  a.col(2).setConstant(1.0);
  const Eigen::Vector3d c(0, 0, -1);
  const Eigen::Vector3d bound(trust, trust, kHuge);
  return SolveSmallLp(c, a, r, bound);
}

// Straightness and flatness: the LP minimises the zone measured along one axis of the frame
// (`across`); re-aligning that axis with the zone's normal and solving again converges to the
// orthogonal zone (the tilt falls by orders of magnitude per pass). A pass is kept only if it
// narrows the zone: among near-equal vertices the LP can return a slightly worse one, and the
// passes then flip-flop (seen on the 43,074 points of the virtual probe's simulated plate face
// in Hostd.AlignsThePlateToPlaneCircleCircle: 11.340 and 11.392 um in turn, the last pass
// deciding which was reported). `realign(frame, local, &tilt)` gives the frame turned by the
// LP's slopes, from the points in `frame` (`local`). On return `*local` holds the points in
// `*f`: one transform per pass. Returns true when a pass no longer narrows the zone or turns
// it (a fixed point); false when the passes ran out first.
template <class Realign>
bool RealignWhileNarrowing(const Points3& points,
                           int across,
                           int passes,
                           const Realign& realign,
                           Frame* f,
                           Points3* local) {
  const auto width = [across](const Points3& l) {
    return l.row(across).maxCoeff() - l.row(across).minCoeff();
  };
  *local = f->Local(points);
  double best = width(*local);
  for (int pass = 0; pass < passes; ++pass) {
    double tilt = 0.0;
    const Frame turned = realign(*f, *local, &tilt);
    Points3 turned_local = turned.Local(points);
    const double turned_width = width(turned_local);
    if (!(turned_width < best)) return true;
    *f = turned, *local = std::move(turned_local), best = turned_width;
    if (tilt < 1e-15) return true;
  }
  return false;
}

Circle3 ToCircle3(const Frame& f, const Vec2& c, double radius) {
  return Circle3{f.origin + f.u * c.x() + f.v * c.y(), f.w, radius};
}

// Smallest enclosing circle of 2 or 3 boundary points.
Circle2 CircleFrom(const Vec2& a, const Vec2& b) { return {(a + b) / 2, (a - b).norm() / 2}; }
Circle2 CircleFrom(const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 ab = b - a, ac = c - a;
  const double d = 2.0 * (ab.x() * ac.y() - ab.y() * ac.x());
  if (std::abs(d) < 1e-300) {  // collinear: the widest pair
    Circle2 best = CircleFrom(a, b);
    for (const Circle2& k : {CircleFrom(a, c), CircleFrom(b, c)})
      best = k.radius > best.radius ? k : best;
    return best;
  }
  const Vec2 o(ac.y() * ab.squaredNorm() - ab.y() * ac.squaredNorm(),
               ab.x() * ac.squaredNorm() - ac.x() * ab.squaredNorm());
  return {a + o / d, (o / d).norm()};
}

bool Inside(const Circle2& c, const Vec2& p) {
  return (p - c.center).norm() <= c.radius * (1.0 + 1e-14) + 1e-300;
}

// Welzl's algorithm in its iterative move-to-front form, on a seeded shuffle (expected O(n)).
Circle2 Welzl(const Points2& points) {
  std::vector<Vec2> p(points.cols());
  for (Eigen::Index i = 0; i < points.cols(); ++i) p[i] = points.col(i);
  std::shuffle(p.begin(), p.end(), std::mt19937_64(0x5eed));
  Circle2 c{p[0], 0.0};
  for (size_t i = 1; i < p.size(); ++i) {
    if (Inside(c, p[i])) continue;
    c = {p[i], 0.0};
    for (size_t j = 0; j < i; ++j) {
      if (Inside(c, p[j])) continue;
      c = CircleFrom(p[i], p[j]);
      for (size_t k = 0; k < j; ++k) {
        if (!Inside(c, p[k])) c = CircleFrom(p[i], p[j], p[k]);
      }
    }
  }
  return c;
}

}  // namespace

void ZoneOptions::Check() const {
  if (max_iterations < 1 || max_iterations > 100000)
    throw GeometryError(ErrorCode::kInvalidArgument,
                        "ZoneOptions.max_iterations must be 1..100000");
}

MinZonePlaneFit FitMinZonePlane(const Points3& points, const ZoneOptions& options) {
  options.Check();
  const auto ls = FitPlane(points);  // checks the input
  Frame f{ls.shape.point, ls.covariance.u, ls.covariance.v, ls.shape.normal};
  const auto realign = [](const Frame& g, const Points3& local, double* tilt) {
    const Eigen::Vector2d slope = MinVerticalZone<2>(local.topRows<2>(), local.row(2).transpose());
    Frame turned = g;
    turned.w = (g.w - slope.x() * g.u - slope.y() * g.v).normalized();
    internal::OrthonormalBasis(turned.w, &turned.u, &turned.v);
    *tilt = slope.norm();
    return turned;
  };
  Points3 local;
  const bool converged = RealignWhileNarrowing(
      points, 2, std::min(kRealignPasses, options.max_iterations), realign, &f, &local);
  const double top = local.row(2).maxCoeff(), bottom = local.row(2).minCoeff();
  MinZonePlaneFit fit;
  fit.plane = Plane{f.origin + f.w * 0.5 * (top + bottom), internal::CanonicalSign<Vec3>(f.w)};
  fit.flatness = top - bottom;
  fit.stats = StatsTo(fit.plane, points);
  fit.stats.converged = converged;
  return fit;
}

MinZoneLineFit FitMinZoneLine(const Points3& points, const ZoneOptions& options) {
  options.Check();
  const auto ls = FitLine3(points);  // checks the input
  // Profile plane: spanned by the line and the direction of largest spread across it.
  Frame f{ls.shape.point, ls.shape.direction, ls.covariance.u, ls.covariance.v};
  const auto realign = [](const Frame& g, const Points3& local, double* tilt) {
    const Eigen::Matrix<double, 1, 1> slope =
        MinVerticalZone<1>(local.topRows<1>(), local.row(1).transpose());
    Frame turned = g;
    turned.u = (g.u + slope(0) * g.v).normalized();
    turned.v = g.w.cross(turned.u);
    *tilt = std::abs(slope(0));
    return turned;
  };
  Points3 local;
  const bool converged = RealignWhileNarrowing(
      points, 1, std::min(kRealignPasses, options.max_iterations), realign, &f, &local);
  const double top = local.row(1).maxCoeff(), bottom = local.row(1).minCoeff();
  MinZoneLineFit fit;
  fit.line = Line3{f.origin + f.v * 0.5 * (top + bottom), internal::CanonicalSign<Vec3>(f.u)};
  fit.plane_normal = f.w;
  fit.straightness = top - bottom;
  const Line2 line2{Vec2(0, 0.5 * (top + bottom)), Vec2::UnitX()};
  fit.stats = internal::ComputeStats(
      points.cols(),
      [&](Eigen::Index i) { return SignedDistance(line2, Vec2(local.col(i).head<2>())); }, 0);
  fit.stats.converged = converged;
  return fit;
}

MinZoneCircleFit FitMinZoneCircle(const Points3& points, const ZoneOptions& options) {
  options.Check();
  const auto ls = FitCircle3(points, RelaxedStart());  // checks the input, gives the start
  Points2 p;
  const Frame f = CirclePlaneFrame(ls, points, &p);
  const Vec2 start = Vec2::Zero();  // the frame is centred on the least-squares circle
  const auto slp = SequentialLp(CentreModel<2>{p}, start, ls.shape.radius, ZoneWidth, ZoneLp<2>,
                                options.max_iterations, "minimum-zone circle");
  const Vec2& c = slp.state;
  const Eigen::VectorXd r = Radii<2>(p, c);
  MinZoneCircleFit fit;
  fit.inner_radius = r.minCoeff();
  fit.outer_radius = r.maxCoeff();
  fit.roundness = fit.outer_radius - fit.inner_radius;
  fit.circle = ToCircle3(f, c, 0.5 * (fit.inner_radius + fit.outer_radius));
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.circle.radius; }, 0);
  fit.stats.converged = ls.stats.converged && slp.converged;
  return fit;
}

MinZoneSphereFit FitMinZoneSphere(const Points3& points, const ZoneOptions& options) {
  options.Check();
  internal::CheckPoints(points, 5, "minimum-zone sphere");
  const auto ls = FitSphere(points, RelaxedStart());  // checks the input, gives the start
  const auto slp = SequentialLp(CentreModel<3>{points}, ls.shape.center, ls.shape.radius, ZoneWidth,
                                ZoneLp<3>, options.max_iterations, "minimum-zone sphere");
  const Eigen::VectorXd r = Radii<3>(points, slp.state);
  MinZoneSphereFit fit;
  fit.inner_radius = r.minCoeff();
  fit.outer_radius = r.maxCoeff();
  fit.sphericity = fit.outer_radius - fit.inner_radius;
  fit.sphere = Sphere{slp.state, 0.5 * (fit.inner_radius + fit.outer_radius)};
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.sphere.radius; }, 0);
  fit.stats.converged = ls.stats.converged && slp.converged;
  return fit;
}

MinZoneCylinderFit FitMinZoneCylinder(const Points3& points,
                                      const ZoneOptions& options,
                                      const std::optional<Cylinder>& initial) {
  options.Check();
  internal::CheckPoints(points, 7, "minimum-zone cylinder");
  const auto ls = FitCylinder(points, RelaxedStart(), initial);  // checks the input, the start
  const Vec3 centroid = points.rowwise().mean();
  const Vec3& axis = ls.shape.axis;
  const AxisModel::State start{ls.shape.point + (centroid - ls.shape.point).dot(axis) * axis, axis};
  const double half_length =
      (axis.transpose() * (points.colwise() - centroid)).cwiseAbs().maxCoeff();
  const AxisModel model{points, centroid, half_length};
  const auto slp = SequentialLp(model, start, ls.shape.radius, ZoneWidth, ZoneLp<4>,
                                options.max_iterations, "minimum-zone cylinder");
  const Eigen::VectorXd r = model.Radii(slp.state);
  MinZoneCylinderFit fit;
  fit.inner_radius = r.minCoeff();
  fit.outer_radius = r.maxCoeff();
  fit.cylindricity = fit.outer_radius - fit.inner_radius;
  fit.cylinder = Cylinder{slp.state.point, internal::CanonicalSign<Vec3>(slp.state.axis),
                          0.5 * (fit.inner_radius + fit.outer_radius)};
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.cylinder.radius; }, 0);
  fit.stats.converged = ls.stats.converged && slp.converged;
  return fit;
}

// The 2D zones are the 3D ones of the points laid in the plane z = 0 (their least-squares plane
// exactly, so the profile plane and the circle's plane are that plane): one solver, tested in
// both, rather than a second copy of the realignment and the sequential LP.
Points3 InPlaneZ0(const Points2& points) {
  Points3 p = Points3::Zero(3, points.cols());
  p.topRows<2>() = points;
  return p;
}

MinZoneLine2Fit FitMinZoneLine2(const Points2& points, const ZoneOptions& options) {
  const MinZoneLineFit zone = FitMinZoneLine(InPlaneZ0(points), options);
  MinZoneLine2Fit fit;
  fit.line = Line2{zone.line.point.head<2>(), zone.line.direction.head<2>().normalized()};
  fit.straightness = zone.straightness;
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return SignedDistance(fit.line, points.col(i).eval()); },
      0);
  fit.stats.converged = zone.stats.converged;
  return fit;
}

MinZoneCircle2Fit FitMinZoneCircle2(const Points2& points, const ZoneOptions& options) {
  const MinZoneCircleFit zone = FitMinZoneCircle(InPlaneZ0(points), options);
  MinZoneCircle2Fit fit;
  fit.circle = Circle2{zone.circle.center.head<2>(), zone.circle.radius};
  fit.roundness = zone.roundness;
  fit.inner_radius = zone.inner_radius;
  fit.outer_radius = zone.outer_radius;
  fit.stats = zone.stats;
  return fit;
}

FunctionalCircleFit FitMaxInscribedCircle(const Points3& points, const ZoneOptions& options) {
  options.Check();
  const auto ls = FitCircle3(points, RelaxedStart());
  Points2 p;
  const Frame f = CirclePlaneFrame(ls, points, &p);
  const Vec2 start = Vec2::Zero();  // the frame is centred on the least-squares circle
  const auto neg_min = [](const Eigen::VectorXd& r) { return -r.minCoeff(); };
  const auto slp = SequentialLp(CentreModel<2>{p}, start, ls.shape.radius, neg_min, InscribedLp,
                                options.max_iterations, "inscribed circle");
  const Vec2& c = slp.state;
  // The centre must lie inside the points' convex hull, or "inscribed" has no meaning: a centre
  // far beyond the least-squares radius means the LP ran away along an open arc.
  if ((c - start).norm() > ls.shape.radius) {
    throw GeometryError(ErrorCode::kUnbounded,
                        "inscribed circle: the points do not enclose a centre");
  }
  const Eigen::VectorXd r = Radii<2>(p, c);
  FunctionalCircleFit fit;
  fit.circle = ToCircle3(f, c, r.minCoeff());
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.circle.radius; }, 0);
  fit.stats.converged = ls.stats.converged && slp.converged;
  return fit;
}

FunctionalCircleFit FitMinCircumscribedCircle(const Points3& points) {
  internal::CheckPoints(points, 2, "circumscribed circle");
  Points2 p;
  const Frame f = CirclePlaneFrame(points, &p);
  const Circle2 c = Welzl(p);
  const Eigen::VectorXd r = Radii<2>(p, c.center);
  FunctionalCircleFit fit;
  fit.circle = ToCircle3(f, c.center, r.maxCoeff());
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.circle.radius; }, 0);
  return fit;
}

}  // namespace mlp::geometry
