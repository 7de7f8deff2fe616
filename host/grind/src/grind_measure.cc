#include "mlp/grind/grind_measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/grind/contour_search.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace mlp::grind {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw GrindError("grind point: " + what); }

// The after-frame's contour within `radius` of `near` (mm). Unordered: the search sorts it its
// own way (contour_search.h), and nothing else depends on the order.
std::vector<Vec2> Contour(const geometry::GreyView& im,
                          const GrindCamera& c,
                          const Vec2& near,
                          double radius) {
  const geometry::Points2 px = geometry::AllCrossings(im, geometry::HalfLevel(im));
  std::vector<Vec2> out;
  for (Eigen::Index i = 0; i < px.cols(); ++i) {
    const Vec2 p = c.ToMm(px.col(i));
    if ((p - near).norm() < radius) out.push_back(p);
  }
  return out;
}

double Bilinear(const geometry::GreyView& im, const Vec2& px) {
  const int u = static_cast<int>(px.x()), v = static_cast<int>(px.y());
  const double fu = px.x() - u, fv = px.y() - v;
  return (1 - fv) * ((1 - fu) * im.At(u, v) + fu * im.At(u + 1, v)) +
         fv * ((1 - fu) * im.At(u, v + 1) + fu * im.At(u + 1, v + 1));
}

// Distance t along u from a (relative to C) back to the wheel's theoretical edge (a - t u on
// it), the root nearer zero; false when the line along u misses the section.
bool BackToEdge(const WheelSection& wheel, const Vec2& a, const Vec2& u, double* t) {
  const std::vector<double> roots = wheel.Crossings(a, -u);
  if (roots.empty()) return false;
  *t = *std::min_element(roots.begin(), roots.end(),
                         [](double x, double y) { return std::abs(x) < std::abs(y); });
  return true;
}

// Spread and mean of the points' distances along the direction at angle phi.
bool Along(const WheelSection& wheel,
           const std::vector<Vec2>& a,
           double phi,
           double* spread,
           double* mean) {
  const Vec2 u(std::cos(phi), std::sin(phi));
  double s = 0, s2 = 0;
  for (const Vec2& q : a) {
    double t = 0;
    if (!BackToEdge(wheel, q, u, &t)) return false;
    s += t, s2 += t * t;
  }
  const double n = static_cast<double>(a.size());
  *mean = s / n, *spread = std::sqrt(std::max(0.0, s2 / n - *mean * *mean));
  return true;
}

// A shift of the nose explains its arc to the edge's noise (0.3 um): beyond this spread the
// nose itself changed (worn smaller, or not round) and a circle is fitted instead.
constexpr double kShiftSpreadMm = 0.001;

// The nose as a circle through the removed region's edge where it is the nose's arc (centre
// and radius free): its centre's shift plus its lost radius along the normal is the error at
// the cutting point (the real nose touches at C + shift - n (R - wear) = Mi + shift + n wear).
void WornNose(const WheelSection& wheel,
              const std::vector<Vec2>& edge,
              const Vec2& n,
              PointResult* res) {
  const double r = wheel.nose_radius_mm();
  std::vector<Vec2> arc;
  for (const Vec2& q : edge)
    if (wheel.NearestOnArc(q)) arc.push_back(q);
  if (arc.size() < 10) return;  // too little arc: the shift's answer stands
  geometry::Points2 pts(2, static_cast<Eigen::Index>(arc.size()));
  for (size_t k = 0; k < arc.size(); ++k) pts.col(static_cast<Eigen::Index>(k)) = arc[k];
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

// Under-feed: where the wheel really was (seed 001, Fig. 4-6), from the removed region's edge.
void UnderFeed(const PointInput& in,
               const GrindCamera& cam,
               const WheelSection& wheel,
               const std::vector<Vec2>& pts,
               const Vec2& n,
               double e,
               PointResult* res) {
  // The removed region's edge: contour points after that were material before: the before
  // frame there (bilinear, at the point itself) darker than its level by 40 % of the grey
  // range, about 0.8 px inside the old edge (a point on the untouched stock reads the level).
  const double before_level = geometry::HalfLevel(in.before) - 0.4 * (cam.bright - cam.dark);
  std::vector<Vec2> edge;
  for (const Vec2& q : pts) {
    const Vec2 px = cam.ToPx(q);
    if (px.x() < 0 || px.y() < 0 || px.x() >= cam.width_px - 1 || px.y() >= cam.height_px - 1)
      continue;
    if (Bilinear(in.before, px) < before_level &&
        wheel.SignedDistanceMm(q - in.c_mm) < 4 * e + res->d_mm)
      edge.push_back(q - in.c_mm);
  }
  res->edge_points = static_cast<int>(edge.size());
  if (edge.size() < 10) {  // the wheel did not cut: the normal and the excess
    res->wheel_cut = false;
    res->compensation_mm = -n * res->d_mm;
    return;
  }
  const double normal = std::atan2(n.y(), n.x());
  double best = normal, best_spread = 1e300, best_mean = 0;
  const auto scan = [&](double from, double to, double step) {
    for (double phi = from; phi <= to + 1e-12; phi += step) {
      double spread = 0, mean = 0;
      if (Along(wheel, edge, phi, &spread, &mean) && spread < best_spread)
        best = phi, best_spread = spread, best_mean = mean;
    }
  };
  scan(normal - M_PI / 2, normal + M_PI / 2, 0.5 / base::kDegPerRad);
  const double coarse = best;
  scan(coarse - 0.5 / base::kDegPerRad, coarse + 0.5 / base::kDegPerRad, 0.01 / base::kDegPerRad);
  res->error_dir = Vec2(std::cos(best), std::sin(best));
  res->error_mm = best_mean, res->spread_mm = best_spread;
  if (best_spread > kShiftSpreadMm) WornNose(wheel, edge, n, res);
  res->compensation_mm = -res->error_dir * res->error_mm;
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
                         double e,
                         const WheelBevel& bevel) {
  if (in.after.width != cam.width_px || in.after.height != cam.height_px ||
      in.before.width != cam.width_px || in.before.height != cam.height_px)
    throw GrindInputError("grind point: a frame's size is not the camera's");
  if (!((in.c_mm - in.mi_mm).norm() > 0.5 * r))
    throw GrindInputError("grind point: C and Mi must be a wheel radius apart");
  const WheelSection wheel(r, bevel);
  const Vec2 u = (in.mi_mm - in.c_mm).normalized();
  const Vec2 n = nominal.Closest(in.mi_mm).normal;
  // Within two nose radii: the search reaches a radius beyond C (the seed's cases 1 and 4).
  const std::vector<Vec2> pts = Contour(in.after, cam, in.mi_mm, 2 * r);
  if (pts.size() < 10) Fail("no contour near Mi");
  PointResult res;
  res.contour_mm = pts;
  const LineCrossing crossing = FindContourOnLine(pts, in.c_mm, in.mi_mm, cam.mm_per_px);
  res.search_case = crossing.seed_case, res.search_by_rows = crossing.by_rows;
  const double t = crossing.t_mm;
  const double ti = (in.mi_mm - in.c_mm).norm();
  res.mr_mm = in.c_mm + t * u;
  res.d_mm = std::abs(t - ti);
  res.feed = res.d_mm <= e ? Feed::kGood : t < ti ? Feed::kUnderFeed : Feed::kOverFeed;
  res.error_dir = n, res.error_mm = res.d_mm;
  if (res.feed == Feed::kOverFeed) res.compensation_mm = n * (res.d_mm + 2 * e);
  if (res.feed != Feed::kUnderFeed) return res;
  UnderFeed(in, cam, wheel, pts, n, e, &res);
  return res;
}

}  // namespace mlp::grind
