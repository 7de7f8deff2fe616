#include "mlp/jobs/feature.h"

#include "mlp/geometry/chebyshev.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mlp::jobs {
namespace {

using geometry::Vec3;
constexpr int kMinWallPoints = 50;

// Two unit vectors perpendicular to `axis` and to each other: machine X projected first (so a
// vertical bore's angles count from +X like a drawing's), any perpendicular when X is the axis.
void Basis(const Vec3& axis, Vec3* u, Vec3* v) {
  const Vec3 x = Vec3::UnitX() - axis.dot(Vec3::UnitX()) * axis;
  *u = x.norm() > 0.1 ? Vec3(x.normalized()) : Vec3(axis.unitOrthogonal());
  *v = axis.cross(*u);
}

// Mean radial deviation from the cylinder per 1-degree bin.
std::vector<double> Profile(const geometry::Points3& pts,
                            const Vec3& centre,
                            const Vec3& axis,
                            double radius) {
  Vec3 u, v;
  Basis(axis, &u, &v);
  std::vector<double> sum(360, 0.0), count(360, 0.0);
  for (Eigen::Index i = 0; i < pts.cols(); ++i) {
    const Vec3 d = pts.col(i) - centre;
    const Vec3 radial = d - d.dot(axis) * axis;
    double deg = std::atan2(radial.dot(v), radial.dot(u)) * 180.0 / M_PI;
    if (deg < 0) deg += 360.0;
    const int bin = std::min(359, static_cast<int>(deg));
    sum[static_cast<size_t>(bin)] += radial.norm() - radius;
    count[static_cast<size_t>(bin)] += 1.0;
  }
  for (size_t b = 0; b < 360; ++b) sum[b] = count[b] > 0 ? sum[b] / count[b] : std::nan("");
  return sum;
}

// 360 deg minus the largest gap between the points' angles around the axis.
double ArcSpanDeg(const geometry::Points3& pts, const Vec3& centre, const Vec3& axis) {
  Vec3 u, v;
  Basis(axis, &u, &v);
  std::vector<double> a;
  for (Eigen::Index i = 0; i < pts.cols(); ++i) {
    const Vec3 d = pts.col(i) - centre;
    a.push_back(std::atan2(d.dot(v), d.dot(u)));
  }
  std::sort(a.begin(), a.end());
  double gap = a.front() + 2 * M_PI - a.back();
  for (size_t i = 1; i < a.size(); ++i) gap = std::max(gap, a[i] - a[i - 1]);
  return 360.0 - gap * 180.0 / M_PI;
}

}  // namespace

BoreMeasurement MeasureBore(const geometry::Points3& points, const BoreNominal& n) {
  if (!(n.diameter_mm > 0) || !(n.depth_mm > 2 * n.edge_margin_mm) || !(n.band_mm > 0) ||
      !(n.axis_mcs.norm() > 0.5))
    throw FeatureError(
        "bore: the nominal needs a diameter > 0, a depth beyond the margins and an "
        "axis");
  const Vec3 axis = n.axis_mcs.normalized();
  const double r = n.diameter_mm / 2;
  std::vector<Eigen::Index> wall;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Vec3 d = points.col(i) - n.top_centre_mcs;
    const double along = d.dot(axis);  // negative: inside the bore
    const double radial = (d - along * axis).norm();
    if (std::abs(radial - r) < n.band_mm && along < -n.edge_margin_mm &&
        along > -(n.depth_mm - n.edge_margin_mm))
      wall.push_back(i);
  }
  if (static_cast<int>(wall.size()) < kMinWallPoints)
    throw FeatureError("bore: " + std::to_string(wall.size()) +
                       " points on the nominal wall, at least " + std::to_string(kMinWallPoints) +
                       " needed (captures looking at the wall? nominal position right?)");
  geometry::Points3 pts(3, static_cast<Eigen::Index>(wall.size()));
  for (size_t k = 0; k < wall.size(); ++k)
    pts.col(static_cast<Eigen::Index>(k)) = points.col(wall[k]);
  geometry::Cylinder start;
  start.point = n.top_centre_mcs;
  start.axis = axis;
  start.radius = r;
  const auto fit = geometry::FitCylinder(pts, {}, start);
  BoreMeasurement m;
  m.axis_mcs = fit.shape.axis.dot(axis) < 0 ? Vec3(-fit.shape.axis) : fit.shape.axis;
  // The fitted axis where it meets the nominal top plane.
  const double t = (n.top_centre_mcs - fit.shape.point).dot(axis) / m.axis_mcs.dot(axis);
  m.top_centre_mcs = fit.shape.point + t * m.axis_mcs;
  m.diameter_mm = 2 * fit.shape.radius;
  m.rms_mm = fit.stats.rms;
  m.max_abs_mm = std::max(-fit.stats.min_residual, fit.stats.max_residual);
  m.points = static_cast<int>(wall.size());
  m.arc_span_deg = ArcSpanDeg(pts, m.top_centre_mcs, m.axis_mcs);
  m.deviation_by_degree_mm = Profile(pts, m.top_centre_mcs, m.axis_mcs, fit.shape.radius);
  // Functional size: the wall points projected along the fitted axis onto one plane.
  geometry::Points3 flat = pts;
  for (Eigen::Index i = 0; i < flat.cols(); ++i) {
    const Vec3 d = flat.col(i) - m.top_centre_mcs;
    flat.col(i) -= d.dot(m.axis_mcs) * m.axis_mcs;
  }
  if (m.arc_span_deg > 180.0) {
    try {
      m.diameter_mic_mm = 2 * geometry::FitMaxInscribedCircle(flat).circle.radius;
    } catch (const geometry::GeometryError& e) {
      if (e.code() != geometry::ErrorCode::kUnbounded) throw;  // patches that enclose no centre
    }
  }
  return m;
}

}  // namespace mlp::jobs
