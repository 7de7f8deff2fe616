#include "mlp/features/composite.h"

#include "mlp/base/units.h"
#include "mlp/geometry/fit.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mlp::features {
namespace {

using geometry::Vec3;

double Deg(double rad) { return base::DegFromRad(rad); }

double AngleBetweenDeg(const Vec3& a, const Vec3& b) {
  // atan2 of the cross and dot products: accurate near 0 deg, where acos loses half the digits.
  return Deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

// Signed turn from `from` to `to` about `axis` (both taken across the axis) [deg].
double TurnAboutDeg(const Vec3& from, const Vec3& to, const Vec3& axis) {
  const Vec3 f = from - from.dot(axis) * axis, t = to - to.dot(axis) * axis;
  return Deg(std::atan2(f.cross(t).dot(axis), f.dot(t)));
}

// A face of a composite feature, with the feature and the face named in its errors.
PlaneMeasurement Face(const geometry::Points3& points,
                      const PlaneNominal& nominal,
                      const std::string& what) {
  try {
    return MeasurePlane(points, nominal);
  } catch (const FeatureError& e) {
    throw FeatureError(what + ": " + e.what());
  }
}

// The angle between a face's normal and a datum direction moves, to first order, only as each
// normal tilts toward the other (a turn about the other's direction leaves it): each face's
// tilt sigma along that direction, in quadrature [rad]. Where the normals are parallel that
// direction is not defined and the angle moves to second order: the larger tilt sigma stands.
double AngleU(const PlaneMeasurement& face, const Vec3& datum, const PlaneMeasurement* datum_face) {
  const Vec3 n = face.plane.normal;
  const Vec3 toward_datum = datum - datum.dot(n) * n;
  const Vec3 toward_face = n - n.dot(datum) * datum;
  constexpr double kParallel = 1e-9;
  const auto tilt = [&](const PlaneMeasurement& f, const Vec3& toward) {
    if (toward.norm() > kParallel) return PlaneTiltU(f, toward.normalized());
    return std::max(PlaneTiltU(f, f.covariance.u), PlaneTiltU(f, f.covariance.v));
  };
  const double u_face = tilt(face, toward_datum);
  const double u_datum = datum_face != nullptr ? tilt(*datum_face, toward_face) : 0.0;
  return std::hypot(u_face, u_datum);
}

Vec3 Unit(const Vec3& v, const std::string& what) {
  if (!(v.norm() > 1e-9) || !v.allFinite()) throw FeatureError(what + " must be a direction");
  return v.normalized();
}

}  // namespace

WidthMeasurement MeasureWidth(const geometry::Points3& points, const WidthNominal& n) {
  if (!(n.width_mm > 0)) throw FeatureError("width: the nominal width must be > 0");
  const Vec3 d = Unit(n.direction_mcs, "width: the nominal direction");
  // The +face's outward normal (out of the material into the air): towards the centre for a
  // slot, away from it for a web. A face proud by h sits h along it.
  const double sigma = n.inside ? -1.0 : 1.0;
  auto face = [&](double side) {
    PlaneNominal p;
    p.point_mcs = n.centre_mcs + side * (n.width_mm / 2) * d;
    p.normal_mcs = side * sigma * d;
    p.band_mm = n.band_mm, p.within_mm = n.within_mm;
    return Face(points, p,
                std::string("width: the face at ") + (side > 0 ? "+" : "-") + "direction");
  };
  WidthMeasurement m;
  m.plus = face(1.0);
  m.minus = face(-1.0);
  // Positions along d on the line through the nominal centre.
  const double at_plus = n.width_mm / 2 + sigma * m.plus.height_mm;
  const double at_minus = -n.width_mm / 2 - sigma * m.minus.height_mm;
  m.width_mm = at_plus - at_minus;
  m.width_u_mm = std::hypot(m.plus.height_u_mm, m.minus.height_u_mm);
  m.centre_mcs = n.centre_mcs + ((at_plus + at_minus) / 2) * d;
  m.parallelism_deg = AngleBetweenDeg(m.plus.plane.normal, -m.minus.plane.normal);
  return m;
}

RectangleMeasurement MeasureRectangle(const geometry::Points3& points, const RectangleNominal& n) {
  const Vec3 axis = Unit(n.axis_mcs, "rectangle: the nominal axis");
  const Vec3 x = Unit(n.x_direction_mcs - n.x_direction_mcs.dot(axis) * axis,
                      "rectangle: the nominal x direction (across the axis)");
  const Vec3 y = axis.cross(x);
  auto width = [&](const Vec3& dir, double size, const char* name) {
    WidthNominal w;
    w.centre_mcs = n.centre_mcs, w.direction_mcs = dir, w.width_mm = size, w.inside = n.inside;
    w.band_mm = n.band_mm, w.within_mm = n.within_mm;
    try {
      return MeasureWidth(points, w);
    } catch (const FeatureError& e) {
      throw FeatureError(std::string("rectangle ") + name + ": " + e.what());
    }
  };
  RectangleMeasurement m;
  m.x = width(x, n.size_x_mm, "x");
  m.y = width(y, n.size_y_mm, "y");
  m.centre_mcs = n.centre_mcs + (m.x.centre_mcs - n.centre_mcs).dot(x) * x +
                 (m.y.centre_mcs - n.centre_mcs).dot(y) * y;
  // Each face's normal against its nominal, about the axis; the mean of the four.
  const double sigma = n.inside ? -1.0 : 1.0;
  m.rotation_deg = (TurnAboutDeg(sigma * x, m.x.plus.plane.normal, axis) +
                    TurnAboutDeg(-sigma * x, m.x.minus.plane.normal, axis) +
                    TurnAboutDeg(sigma * y, m.y.plus.plane.normal, axis) +
                    TurnAboutDeg(-sigma * y, m.y.minus.plane.normal, axis)) /
                   4;
  return m;
}

StepMeasurement MeasureStep(const geometry::Points3& points, const StepNominal& n) {
  StepMeasurement m;
  m.a = Face(points, n.a, "step: face A");
  m.b = Face(points, n.b, "step: face B");
  const Vec3 b_at_nominal = n.b.point_mcs + m.b.height_mm * n.b.normal_mcs.normalized();
  m.height_mm = (b_at_nominal - m.a.plane.point).dot(m.a.plane.normal);
  m.height_u_mm = std::hypot(m.b.height_u_mm, PlaneHeightU(m.a, b_at_nominal));
  m.parallelism_deg = AngleBetweenDeg(m.a.plane.normal, m.b.plane.normal);
  return m;
}

AngleMeasurement MeasureAngle(const geometry::Points3& points, const AngleNominal& n) {
  AngleMeasurement m;
  m.face = Face(points, n.face, "angle: the face");
  Vec3 datum = Unit(n.datum.normal_mcs, "angle: the datum normal");
  if (n.datum_face) {
    m.datum = Face(points, n.datum, "angle: the datum face");
    datum = m.datum.plane.normal;
  }
  m.angle_deg = AngleBetweenDeg(m.face.plane.normal, datum);
  m.angle_u_deg = Deg(AngleU(m.face, datum, n.datum_face ? &m.datum : nullptr));
  m.skew_deg = AngleBetweenDeg(m.face.plane.normal, n.face.normal_mcs.normalized());
  return m;
}

PcdMeasurement MeasurePcd(const geometry::Points3& points, const PcdNominal& n) {
  if (n.holes.size() < 3) throw FeatureError("pcd: at least 3 holes are needed for a circle");
  if (!(n.diameter_mm > 0)) throw FeatureError("pcd: the nominal diameter must be > 0");
  PcdMeasurement m;
  geometry::Points3 centres(3, static_cast<Eigen::Index>(n.holes.size()));
  for (size_t k = 0; k < n.holes.size(); ++k) {
    try {
      m.holes.push_back(MeasureBore(points, n.holes[k]));
    } catch (const FeatureError& e) {
      throw FeatureError("pcd: hole " + std::to_string(k + 1) + ": " + e.what());
    }
    centres.col(static_cast<Eigen::Index>(k)) = m.holes.back().top_centre_mcs;
  }
  geometry::FitOptions options;
  options.require_convergence = false;  // the gate refuses an estimate
  const auto circle = geometry::FitCircle3(centres, options);
  m.converged = circle.stats.converged;
  for (const BoreMeasurement& hole : m.holes) m.converged = m.converged && hole.converged;
  m.centre_mcs = circle.shape.center;
  m.diameter_mm = 2 * circle.shape.radius;
  m.diameter_u_mm = 2 * circle.covariance.StdDev("radius");
  m.rms_mm = circle.stats.rms;
  Vec3 axis = circle.shape.normal;
  if (axis.dot(n.holes.front().axis_mcs) < 0) axis = -axis;
  double turn = 0;
  for (size_t k = 0; k < n.holes.size(); ++k) {
    const Vec3 a = n.holes[k].axis_mcs.normalized();
    const Vec3 d = m.holes[k].top_centre_mcs - n.holes[k].top_centre_mcs;
    m.true_position_mm.push_back(2 * (d - d.dot(a) * a).norm());
    turn += TurnAboutDeg(n.holes[k].top_centre_mcs - n.centre_mcs,
                         m.holes[k].top_centre_mcs - m.centre_mcs, axis);
  }
  m.rotation_deg = turn / static_cast<double>(n.holes.size());
  return m;
}

EllipseMeasurement MeasureEllipse(const geometry::Points3& points, const EllipseNominal& n) {
  const double a = n.major_mm / 2, b = n.minor_mm / 2;
  if (!(b > 0) || !(a >= b) || !(n.depth_mm > 2 * n.edge_margin_mm) || !(n.band_mm > 0))
    throw FeatureError(
        "ellipse: the nominal needs major >= minor > 0, a depth beyond the margins and a band");
  const Vec3 axis = Unit(n.axis_mcs, "ellipse: the nominal axis");
  const Vec3 u = Unit(n.major_direction_mcs - n.major_direction_mcs.dot(axis) * axis,
                      "ellipse: the nominal major direction (across the axis)");
  const Vec3 v = axis.cross(u);
  std::vector<geometry::Vec2> wall;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const Vec3 d = points.col(i) - n.top_centre_mcs;
    const double along = d.dot(axis), x = d.dot(u), y = d.dot(v);
    if (along > -n.edge_margin_mm || along < -(n.depth_mm - n.edge_margin_mm)) continue;
    // Distance to the nominal ellipse along the ray from its centre: exact enough to segment.
    const double k = std::hypot(x / a, y / b), r = std::hypot(x, y);
    if (k > 0 && std::abs(r * (1 - 1 / k)) < n.band_mm) wall.emplace_back(x, y);
  }
  constexpr size_t kMinWallPoints = 50;
  if (wall.size() < kMinWallPoints)
    throw FeatureError("ellipse: " + std::to_string(wall.size()) +
                       " points on the nominal wall, at least 50 needed");
  geometry::Points2 pts(2, static_cast<Eigen::Index>(wall.size()));
  for (size_t k = 0; k < wall.size(); ++k) pts.col(static_cast<Eigen::Index>(k)) = wall[k];
  geometry::FitOptions options;
  options.require_convergence = false;  // the gate refuses an estimate
  const auto fit = geometry::FitEllipse2(pts, options);
  EllipseMeasurement m;
  m.converged = fit.stats.converged;
  m.top_centre_mcs = n.top_centre_mcs + fit.shape.center.x() * u + fit.shape.center.y() * v;
  m.major_mm = 2 * fit.shape.semi_major;
  m.minor_mm = 2 * fit.shape.semi_minor;
  m.major_u_mm = 2 * fit.covariance.StdDev("semi_major");
  m.minor_u_mm = 2 * fit.covariance.StdDev("semi_minor");
  m.rotation_deg = Deg(fit.shape.angle);
  if (m.rotation_deg > 90) m.rotation_deg -= 180;
  m.rms_mm = fit.stats.rms;
  m.max_abs_mm = std::max(-fit.stats.min_residual, fit.stats.max_residual);
  m.points = static_cast<int>(wall.size());
  return m;
}

}  // namespace mlp::features
