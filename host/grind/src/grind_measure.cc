#include "mlp/grind/grind_measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mlp::grind {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw GrindError("grind point: " + what); }

struct ContourPoint {
  Vec2 p;    // mm
  double s;  // along the nominal
};

// The after-frame's contour within `radius` of `near`, sorted along the nominal.
std::vector<ContourPoint> Contour(const geometry::GreyView& im,
                                  const GrindCamera& c,
                                  const geometry::Profile2& nominal,
                                  const Vec2& near,
                                  double radius) {
  const geometry::Points2 px = geometry::AllCrossings(im, geometry::HalfLevel(im));
  std::vector<ContourPoint> out;
  for (Eigen::Index i = 0; i < px.cols(); ++i) {
    const Vec2 p = c.ToMm(px.col(i));
    if ((p - near).norm() < radius) out.push_back({p, nominal.Closest(p).s});
  }
  std::sort(out.begin(), out.end(),
            [](const ContourPoint& a, const ContourPoint& b) { return a.s < b.s; });
  return out;
}

// The seed's directed search for the contour on the line through C along u, then a line
// through the contour round there intersected with it: the distance from C along u.
double ContourOnLine(const std::vector<ContourPoint>& pts,
                     const Vec2& c,
                     const Vec2& u,
                     const Vec2& mi,
                     double px_mm) {
  const Vec2 w(-u.y(), u.x());
  const auto off = [&](size_t i) { return (pts[i].p - c).dot(w); };
  size_t i = 0;
  for (size_t k = 1; k < pts.size(); ++k)
    if ((pts[k].p - mi).norm() < (pts[i].p - mi).norm()) i = k;
  const int step =
      (i + 1 < pts.size() && (i == 0 || std::abs(off(i + 1)) < std::abs(off(i - 1)))) ? 1 : -1;
  for (;;) {
    const long next = static_cast<long>(i) + step;
    if (next < 0 || next >= static_cast<long>(pts.size())) break;
    const bool crosses = (off(i) > 0) != (off(static_cast<size_t>(next)) > 0);
    const bool grows = std::abs(off(static_cast<size_t>(next))) > std::abs(off(i));
    if (crosses || (grows && std::abs(off(i)) < px_mm)) break;
    i = static_cast<size_t>(next);
  }
  if (std::abs(off(i)) > 3 * px_mm) Fail("no contour on the line from C to Mi");
  geometry::Points2 local(2, 0);
  std::vector<Vec2> near;
  for (const ContourPoint& q : pts)
    if ((q.p - pts[i].p).norm() < 3 * px_mm) near.push_back(q.p);
  if (near.size() >= 3) {
    local.resize(2, static_cast<Eigen::Index>(near.size()));
    for (size_t k = 0; k < near.size(); ++k) local.col(static_cast<Eigen::Index>(k)) = near[k];
    try {
      const auto line = geometry::FitLine2(local);
      const Vec2 n(-line.shape.direction.y(), line.shape.direction.x());
      const double den = u.dot(n);
      if (std::abs(den) > 0.2) return (line.shape.point - c).dot(n) / den;
    } catch (const geometry::GeometryError&) {
    }
  }
  return (pts[i].p - c).dot(u);  // too few points for a line: the nearest
}

double Bilinear(const geometry::GreyView& im, const Vec2& px) {
  const int u = static_cast<int>(px.x()), v = static_cast<int>(px.y());
  const double fu = px.x() - u, fv = px.y() - v;
  return (1 - fv) * ((1 - fu) * im.At(u, v) + fu * im.At(u + 1, v)) +
         fv * ((1 - fu) * im.At(u, v + 1) + fu * im.At(u + 1, v + 1));
}

// Distance t along u from p back to the theoretical nose circle (|p - t u - C| = R), the root
// nearer zero; false when the line along u misses the circle.
bool BackToCircle(const Vec2& a, const Vec2& u, double r, double* t) {
  const double au = a.dot(u), disc = au * au - a.squaredNorm() + r * r;
  if (disc < 0) return false;
  const double t1 = au - std::sqrt(disc), t2 = au + std::sqrt(disc);
  *t = std::abs(t1) < std::abs(t2) ? t1 : t2;
  return true;
}

// Spread and mean of the points' distances along the direction at angle phi.
bool Along(const std::vector<Vec2>& a, double phi, double r, double* spread, double* mean) {
  const Vec2 u(std::cos(phi), std::sin(phi));
  double s = 0, s2 = 0;
  for (const Vec2& q : a) {
    double t = 0;
    if (!BackToCircle(q, u, r, &t)) return false;
    s += t, s2 += t * t;
  }
  const double n = static_cast<double>(a.size());
  *mean = s / n, *spread = std::sqrt(std::max(0.0, s2 / n - *mean * *mean));
  return true;
}

// A shift of the nose explains its arc to the edge's noise (0.3 um): beyond this spread the
// nose itself changed (worn smaller, or not round) and a circle is fitted instead.
constexpr double kShiftSpreadMm = 0.001;

// The nose as a circle through the removed region's edge (centre and radius free): its
// centre's shift plus its lost radius along the normal is the error at the cutting point
// (the real nose touches at C + shift - n (R - wear) = Mi + shift + n wear).
void WornNose(const std::vector<Vec2>& edge, const Vec2& n, double r, PointResult* res) {
  geometry::Points2 pts(2, static_cast<Eigen::Index>(edge.size()));
  for (size_t k = 0; k < edge.size(); ++k) pts.col(static_cast<Eigen::Index>(k)) = edge[k];
  try {
    const auto circle = geometry::FitCircle2(pts);
    const Vec2 error = circle.shape.center + n * (r - circle.shape.radius);
    if (!(error.norm() > 0) || !error.allFinite()) return;
    res->error_dir = error.normalized(), res->error_mm = error.norm();
    res->nose_radius_mm = circle.shape.radius;
    res->spread_mm = circle.stats.rms;
  } catch (const geometry::GeometryError&) {  // the arc too short: the shift's answer stands
  }
}

}  // namespace

const char* ToString(Feed f) {
  switch (f) {
    case Feed::kGood:
      return "good";
    case Feed::kUnderFeed:
      return "under-feed";
    case Feed::kOverFeed:
      return "over-feed";
  }
  return "?";
}

PointResult MeasurePoint(const PointInput& in,
                         const geometry::Profile2& nominal,
                         const GrindCamera& cam,
                         double r,
                         double e) {
  if (in.after.width != cam.width_px || in.after.height != cam.height_px ||
      in.before.width != cam.width_px || in.before.height != cam.height_px)
    throw GrindInputError("grind point: a frame's size is not the camera's");
  if (!((in.c_mm - in.mi_mm).norm() > 0.5 * r))
    throw GrindInputError("grind point: C and Mi must be a wheel radius apart");
  const Vec2 u = (in.mi_mm - in.c_mm).normalized();
  const Vec2 n = nominal.Closest(in.mi_mm).normal;
  const std::vector<ContourPoint> pts = Contour(in.after, cam, nominal, in.mi_mm, 1.2 * r);
  if (pts.size() < 10) Fail("no contour near Mi");
  PointResult res;
  for (const ContourPoint& q : pts) res.contour_mm.push_back(q.p);
  const double t = ContourOnLine(pts, in.c_mm, u, in.mi_mm, cam.mm_per_px);
  const double ti = (in.mi_mm - in.c_mm).norm();
  res.mr_mm = in.c_mm + t * u;
  res.d_mm = std::abs(t - ti);
  res.feed = res.d_mm <= e ? Feed::kGood : t < ti ? Feed::kUnderFeed : Feed::kOverFeed;
  res.error_dir = n, res.error_mm = res.d_mm;
  if (res.feed == Feed::kOverFeed) res.compensation_mm = n * (res.d_mm + 2 * e);
  if (res.feed != Feed::kUnderFeed) return res;
  // The removed region's edge: contour points after that were material before: the before
  // frame there (bilinear, at the point itself) darker than its level by 40 % of the grey
  // range, about 0.8 px inside the old edge (a point on the untouched stock reads the level).
  const double before_level = geometry::HalfLevel(in.before) - 0.4 * (cam.bright - cam.dark);
  std::vector<Vec2> edge;
  for (const ContourPoint& q : pts) {
    const Vec2 px = cam.ToPx(q.p);
    if (px.x() < 0 || px.y() < 0 || px.x() >= cam.width_px - 1 || px.y() >= cam.height_px - 1)
      continue;
    if (Bilinear(in.before, px) < before_level && (q.p - in.c_mm).norm() < r + 4 * e + res.d_mm)
      edge.push_back(q.p - in.c_mm);
  }
  res.edge_points = static_cast<int>(edge.size());
  if (edge.size() < 10) {  // the wheel did not cut: the normal and the excess
    res.wheel_cut = false;
    res.compensation_mm = -n * res.d_mm;
    return res;
  }
  const double normal = std::atan2(n.y(), n.x());
  double best = normal, best_spread = 1e300, best_mean = 0;
  const auto scan = [&](double from, double to, double step) {
    for (double phi = from; phi <= to + 1e-12; phi += step) {
      double spread = 0, mean = 0;
      if (Along(edge, phi, r, &spread, &mean) && spread < best_spread)
        best = phi, best_spread = spread, best_mean = mean;
    }
  };
  scan(normal - M_PI / 2, normal + M_PI / 2, 0.5 / base::kDegPerRad);
  const double coarse = best;
  scan(coarse - 0.5 / base::kDegPerRad, coarse + 0.5 / base::kDegPerRad, 0.01 / base::kDegPerRad);
  res.error_dir = Vec2(std::cos(best), std::sin(best));
  res.error_mm = best_mean, res.spread_mm = best_spread;
  if (best_spread > kShiftSpreadMm) WornNose(edge, n, r, &res);
  res.compensation_mm = -res.error_dir * res.error_mm;
  return res;
}

}  // namespace mlp::grind
