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
// still a start, and the fit says so (stats.converged) rather than giving no answer.
FitOptions RelaxedStart() {
  FitOptions o;
  o.require_convergence = false;
  return o;
}

// Radii from a centre, and unit directions.
Eigen::VectorXd Radii(const Points2& p, const Vec2& c) {
  return (p.colwise() - c).colwise().norm();
}

struct SlpResult {
  Vec2 center;
  /// The step fell to rounding or the trust region shrank to nothing: a stationary point. False:
  /// the iterations ran out, and `center` is the best iterate.
  bool converged = false;
};

// Sequential LP for circle zones. `objective(radii)` is the true objective (to minimise);
// `build(c, radii, dirs, trust)` makes the linearised LP; returns the centre.
SlpResult SequentialLp(
    const Points2& p,
    Vec2 center,
    double scale,
    const std::function<double(const Eigen::VectorXd&)>& objective,
    const std::function<internal::LpResult(const Eigen::VectorXd&, const Points2&, double)>&
        solve_lp,
    int max_iterations,
    const char* what) {
  double trust = 0.1 * scale;
  double best = objective(Radii(p, center));
  for (int it = 0; it < max_iterations; ++it) {
    if (trust <= 1e-14 * scale) return {center, true};
    const Eigen::VectorXd r = Radii(p, center);
    Points2 dirs = p.colwise() - center;
    for (Eigen::Index i = 0; i < p.cols(); ++i) dirs.col(i) /= std::max(r(i), 1e-300);
    const auto lp = solve_lp(r, dirs, trust);
    if (!lp.optimal)
      throw GeometryError(ErrorCode::kNotConverged, std::string(what) + ": LP failed");
    for (size_t k = 2; k < lp.bound_active.size(); ++k) {
      if (lp.bound_active[k]) {
        throw GeometryError(ErrorCode::kUnbounded,
                            std::string(what) + ": the points do not enclose a centre");
      }
    }
    const Vec2 step = lp.x.head<2>();
    const double value = objective(Radii(p, center + step));
    if (value < best) {
      center += step, best = value;
      if (step.norm() < 0.5 * trust) trust = std::max(step.norm(), 1e-14 * scale);
    } else {
      trust *= 0.25;
    }
    if (step.norm() <= 1e-13 * scale) return {center, true};
  }
  return {center, trust <= 1e-14 * scale};
}

// Minimum-zone circle: variables (dx, dy, outer, inner): r_i - u_i.d <= outer, >= inner.
internal::LpResult ZoneLp(const Eigen::VectorXd& r, const Points2& u, double trust) {
  const Eigen::Index n = r.size();
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n, 4);
  Eigen::VectorXd b(2 * n);
  a.topLeftCorner(n, 2) = -u.transpose();
  a.col(2).head(n).setConstant(-1.0);
  b.head(n) = -r;
  a.bottomLeftCorner(n, 2) = u.transpose();
  a.col(3).tail(n).setConstant(1.0);
  b.tail(n) = r;
  const Eigen::Vector4d c(0, 0, 1, -1);
  const Eigen::Vector4d bound(trust, trust, kHuge, kHuge);
  return SolveSmallLp(c, a, b, bound);
}

// Maximum inscribed: maximise R with R + u_i.d <= r_i.
internal::LpResult InscribedLp(const Eigen::VectorXd& r, const Points2& u, double trust) {
  const Eigen::Index n = r.size();
  Eigen::MatrixXd a(n, 3);
  a.leftCols(2) = u.transpose();
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
  const auto width = [](const Eigen::VectorXd& r) { return r.maxCoeff() - r.minCoeff(); };
  const SlpResult slp = SequentialLp(p, start, ls.shape.radius, width, ZoneLp,
                                     options.max_iterations, "minimum-zone circle");
  const Vec2& c = slp.center;
  const Eigen::VectorXd r = Radii(p, c);
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

FunctionalCircleFit FitMaxInscribedCircle(const Points3& points, const ZoneOptions& options) {
  options.Check();
  const auto ls = FitCircle3(points, RelaxedStart());
  Points2 p;
  const Frame f = CirclePlaneFrame(ls, points, &p);
  const Vec2 start = Vec2::Zero();  // the frame is centred on the least-squares circle
  const auto neg_min = [](const Eigen::VectorXd& r) { return -r.minCoeff(); };
  const SlpResult slp = SequentialLp(p, start, ls.shape.radius, neg_min, InscribedLp,
                                     options.max_iterations, "inscribed circle");
  const Vec2& c = slp.center;
  // The centre must lie inside the points' convex hull, or "inscribed" has no meaning: a centre
  // far beyond the least-squares radius means the LP ran away along an open arc.
  if ((c - start).norm() > ls.shape.radius) {
    throw GeometryError(ErrorCode::kUnbounded,
                        "inscribed circle: the points do not enclose a centre");
  }
  const Eigen::VectorXd r = Radii(p, c);
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
  const Eigen::VectorXd r = Radii(p, c.center);
  FunctionalCircleFit fit;
  fit.circle = ToCircle3(f, c.center, r.maxCoeff());
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return r(i) - fit.circle.radius; }, 0);
  return fit;
}

}  // namespace mlp::geometry
