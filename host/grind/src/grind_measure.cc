#include "mlp/grind/grind_measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"
#include "mlp/grind/contour_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

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

// An edge point this far (and 4 robust sigma) from the wheel's edge at the shift found is not
// the wheel's: a droplet, a burr, a chip (the edge's own noise is 0.2-0.5 um).
constexpr double kNuisanceMm = 0.003;

// The points the wheel's edge, shifted along `phi` by their distances' median, explains (the
// median: a droplet pulls the mean).
std::vector<Vec2> Explained(const WheelSection& wheel, const std::vector<Vec2>& edge, double phi) {
  const Vec2 u(std::cos(phi), std::sin(phi));
  std::vector<double> along, off;
  for (const Vec2& q : edge) {
    double t = 0;
    along.push_back(BackToEdge(wheel, q, u, &t) ? t : 1e300);
  }
  const double centre = geometry::Median(along);
  for (double t : along) off.push_back(std::abs(t - centre));
  const double limit = std::max(kNuisanceMm, 4 * 1.4826 * geometry::Median(off));
  std::vector<Vec2> kept;
  for (size_t k = 0; k < edge.size(); ++k)
    if (off[k] <= limit) kept.push_back(edge[k]);
  return kept;
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

// The wheel's error found from the removed region's edge must agree with what the crossing on
// C-Mi measured: the error's part along the normal is the material left there (a shift s of
// the nose leaves s . n + |s x n|^2 / 2R along the normal; a worn nose, its lost radius), to
// the edge's noise and a share of d for the neglected terms. A droplet or a burr on the edge
// pulls the fit and not the crossing: 38-253 um at 135-150 deg from the normal where the
// crossing said 12 um (issue 55's outside renderer). And a nose fitted far from the wheel's
// radius is not the nose: refused, never compensated.
constexpr double kAgreeMm = 0.002, kAgreeShare = 0.25;
constexpr double kMaxNoseChange = 0.05;  // of the radius: a nose worn further is re-dressed

void CheckAgainstCrossing(const PointResult& res, const Vec2& n, double r) {
  const double along = res.error_mm * res.error_dir.dot(n);
  const auto um = [](double mm) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f", mm * 1e3);
    return std::string(text);
  };
  if (!(std::abs(along - res.d_mm) <= kAgreeMm + kAgreeShare * res.d_mm))
    Fail("the removed region's edge puts the wheel " + um(res.error_mm) + " um off at " +
         std::to_string(std::lround(std::acos(std::clamp(res.error_dir.dot(n), -1.0, 1.0)) *
                                    base::kDegPerRad)) +
         " deg from the normal, " + um(along) + " um along it, where the contour on C-Mi left " +
         um(res.d_mm) +
         " um: something on the edge (a droplet, a burr) that no wheel position "
         "explains; not compensated");
  if (res.nose_radius_mm > 0 && !(std::abs(res.nose_radius_mm - r) <= kMaxNoseChange * r))
    Fail("the removed region's arc fits a nose of radius " + um(res.nose_radius_mm) +
         " um where the wheel's is " + um(r) +
         " um: not the nose (a droplet, a burr) or a "
         "wheel worn beyond 5 % of its radius; not compensated");
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
  const auto smallest_spread = [&] {
    best = normal, best_spread = 1e300, best_mean = 0;
    scan(normal - M_PI / 2, normal + M_PI / 2, 0.5 / base::kDegPerRad);
    const double coarse = best;
    scan(coarse - 0.5 / base::kDegPerRad, coarse + 0.5 / base::kDegPerRad, 0.01 / base::kDegPerRad);
  };
  smallest_spread();
  // Nuisances found, not fitted (issue 55): a droplet or burr on the edge makes points no
  // wheel position explains; at the direction found, the points off the wheel's edge by more
  // than kNuisanceMm (and 4 robust sigma) leave, and the search runs again, until none leave.
  // Over a quarter left out: the evidence is spoiled (or the wheel is not the job's), refused.
  for (int round = 0; round < 3 && best_spread < 1e300; ++round) {
    const size_t before = edge.size();
    edge = Explained(wheel, edge, best);
    if (edge.size() == before) break;
    res->left_out += static_cast<int>(before - edge.size());
    if (edge.size() < 10 || 4 * res->left_out > res->edge_points)
      Fail("over a quarter of the removed region's edge is off any wheel position (" +
           std::to_string(res->left_out) + " of " + std::to_string(res->edge_points) +
           " points: a droplet, a burr, or not the job's wheel shape); not compensated");
    smallest_spread();
  }
  res->error_dir = Vec2(std::cos(best), std::sin(best));
  res->error_mm = best_mean, res->spread_mm = best_spread;
  if (best_spread > kShiftSpreadMm) WornNose(wheel, edge, n, res);
  CheckAgainstCrossing(*res, n, wheel.nose_radius_mm());
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
