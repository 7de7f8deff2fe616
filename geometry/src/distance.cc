#include "mlp/geometry/distance.h"

#include <cmath>

#include "common.h"

namespace mlp::geometry {
namespace {

// Root of (r0 z0 / (s + r0))^2 + (z1 / (s + 1))^2 - 1 by bisection (Eberly 2013, listing 2):
// bisection to the last bit is what makes it robust for points near the axes and the centre.
double EllipseRoot(double r0, double z0, double z1, double g) {
  const double n0 = r0 * z0;
  double s0 = z1 - 1.0;
  double s1 = g < 0.0 ? 0.0 : std::hypot(n0, z1) - 1.0;
  double s = 0.0;
  for (int i = 0; i < 1100; ++i) {
    s = 0.5 * (s0 + s1);
    if (s == s0 || s == s1) break;
    const double ratio0 = n0 / (s + r0);
    const double ratio1 = z1 / (s + 1.0);
    const double gs = ratio0 * ratio0 + ratio1 * ratio1 - 1.0;
    if (gs > 0.0) {
      s0 = s;
    } else if (gs < 0.0) {
      s1 = s;
    } else {
      break;
    }
  }
  return s;
}

// Foot point for e0 >= e1 > 0 and a point in the first quadrant (y0, y1 >= 0).
Vec2 FootFirstQuadrant(double e0, double e1, double y0, double y1) {
  if (y1 > 0.0) {
    if (y0 > 0.0) {
      const double z0 = y0 / e0, z1 = y1 / e1;
      const double g = z0 * z0 + z1 * z1 - 1.0;
      if (g == 0.0) return {y0, y1};
      const double r0 = (e0 / e1) * (e0 / e1);
      const double sbar = EllipseRoot(r0, z0, z1, g);
      return {r0 * y0 / (sbar + r0), y1 / (sbar + 1.0)};
    }
    return {0.0, e1};
  }
  const double numer0 = e0 * y0, denom0 = e0 * e0 - e1 * e1;
  if (numer0 < denom0) {
    const double xde0 = numer0 / denom0;
    return {e0 * xde0, e1 * std::sqrt(std::max(0.0, 1.0 - xde0 * xde0))};
  }
  return {e0, 0.0};
}

Vec3 PlanePoint(
    const Vec3& center, const Vec3& normal, const Vec3& p, Vec2* in_plane, const Vec3& x_axis) {
  Vec3 q = p - center;
  const Vec3 y_axis = normal.cross(x_axis);
  *in_plane = Vec2(q.dot(x_axis), q.dot(y_axis));
  return q;
}

}  // namespace

Vec2 EllipseFootPoint(double a, double b, const Vec2& p) {
  const bool swapped = b > a;  // Eberly's algorithm wants the major axis first
  const double e0 = swapped ? b : a, e1 = swapped ? a : b;
  const double y0 = std::abs(swapped ? p.y() : p.x());
  const double y1 = std::abs(swapped ? p.x() : p.y());
  Vec2 f = FootFirstQuadrant(e0, e1, y0, y1);
  if (swapped) std::swap(f.x(), f.y());
  return {std::copysign(f.x(), p.x()), std::copysign(f.y(), p.y())};
}

double SignedDistance(const Line2& line, const Vec2& p) {
  const Vec2 normal(-line.direction.y(), line.direction.x());
  return (p - line.point).dot(normal);
}

double SignedDistance(const Line3& line, const Vec3& p) {
  return (p - line.point).cross(line.direction).norm();
}

double SignedDistance(const Plane& plane, const Vec3& p) {
  return (p - plane.point).dot(plane.normal);
}

double SignedDistance(const Circle2& circle, const Vec2& p) {
  return (p - circle.center).norm() - circle.radius;
}

double SignedDistance(const Circle3& circle, const Vec3& p) {
  const Vec3 q = p - circle.center;
  const double h = q.dot(circle.normal);
  const double rho = (q - h * circle.normal).norm();
  return std::hypot(rho - circle.radius, h);
}

double SignedDistance(const Sphere& sphere, const Vec3& p) {
  return (p - sphere.center).norm() - sphere.radius;
}

double SignedDistance(const Cylinder& cylinder, const Vec3& p) {
  return (p - cylinder.point).cross(cylinder.axis).norm() - cylinder.radius;
}

double SignedDistance(const Cone& cone, const Vec3& p) {
  const Vec3 q = p - cone.point;
  const double h = q.dot(cone.axis);
  const double rho = (q - h * cone.axis).norm();
  return rho * std::cos(cone.half_angle) - h * std::sin(cone.half_angle) - cone.distance;
}

double SignedDistance(const Ellipse2& e, const Vec2& p) {
  const Eigen::Rotation2Dd rot(e.angle);
  const Vec2 q = rot.inverse() * (p - e.center);
  const Vec2 f = EllipseFootPoint(e.semi_major, e.semi_minor, q);
  const double inside = (q.x() / e.semi_major) * (q.x() / e.semi_major) +
                        (q.y() / e.semi_minor) * (q.y() / e.semi_minor);
  const double d = (q - f).norm();
  return inside < 1.0 ? -d : d;
}

double SignedDistance(const Ellipse3& e, const Vec3& p) {
  Vec2 in_plane;
  const Vec3 q = PlanePoint(e.center, e.normal, p, &in_plane, e.major_axis);
  const double d =
      SignedDistance(Ellipse2{Vec2::Zero(), 0.0, e.semi_major, e.semi_minor}, in_plane);
  const double h = q.dot(e.normal);
  return std::copysign(std::hypot(d, h), d);
}

}  // namespace mlp::geometry
