#include "mlp/geometry/datum.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"

#include <cmath>

namespace mlp::geometry {
namespace {

// Below this sine the secondary direction is too close to the plane normal to define X.
constexpr double kMinProjectedSine = 1e-6;

Pose3 FromAxes(const Vec3& x, const Vec3& y, const Vec3& z, const Vec3& origin) {
  Pose3 pose = Pose3::Identity();
  pose.linear().col(0) = x;
  pose.linear().col(1) = y;
  pose.linear().col(2) = z;
  pose.translation() = origin;
  return pose;
}

// `v` projected on the plane with unit normal `n`, normalised; throws when it vanishes.
Vec3 InPlane(const Vec3& v, const Vec3& n, const char* what) {
  const Vec3 p = v - v.dot(n) * n;
  if (!(p.norm() > kMinProjectedSine * v.norm())) {
    throw GeometryError(ErrorCode::kDegenerate,
                        std::string(what) + " is perpendicular to the primary plane");
  }
  return p.normalized();
}

Vec3 ProjectOnPlane(const Vec3& p, const Plane& plane) {
  return p - (p - plane.point).dot(plane.normal) * plane.normal;
}

}  // namespace

Pose3 DatumPlaneLinePoint(const Plane& primary, const Line3& secondary, const Vec3& tertiary) {
  const Vec3 z = primary.normal.normalized();
  const Vec3 x = InPlane(secondary.direction, z, "the secondary line");
  const Vec3 y = z.cross(x);
  const Vec3 line_point = ProjectOnPlane(secondary.point, primary);
  const Vec3 origin = line_point + x * (ProjectOnPlane(tertiary, primary) - line_point).dot(x);
  return FromAxes(x, y, z, origin);
}

Pose3 DatumPlaneCircleCircle(const Plane& a, const Vec3& center_b, const Vec3& center_c) {
  const Vec3 z = a.normal.normalized();
  const Vec3 origin = ProjectOnPlane(center_b, a);
  const Vec3 y = InPlane(center_c - center_b, z, "the line B->C");
  return FromAxes(y.cross(z), y, z, origin);
}

WorkOffsetReading ReadWorkOffset(const Pose3& mcs_from_work) {
  WorkOffsetReading r;
  const Mat3 rot = mcs_from_work.linear();
  r.origin_mm = mcs_from_work.translation();
  r.rotation_z_deg = std::atan2(rot(1, 0), rot(0, 0)) * base::kDegPerRad;
  r.tilt_deg = std::acos(std::clamp(rot(2, 2), -1.0, 1.0)) * base::kDegPerRad;
  // R = Rz(c) Ry(b) Rx(a).
  const double b = std::asin(std::clamp(-rot(2, 0), -1.0, 1.0));
  const double a = std::atan2(rot(2, 1), rot(2, 2));
  const double c = std::atan2(rot(1, 0), rot(0, 0));
  r.euler_zyx_deg = Vec3(a, b, c) * base::kDegPerRad;
  return r;
}

Points3 TransformPoints(const Pose3& target_from_source, const Points3& points_in_source) {
  return (target_from_source.linear() * points_in_source).colwise() +
         target_from_source.translation();
}

}  // namespace mlp::geometry
