#pragma once
/// @file Value types of the geometry layer: points, poses and the fitted primitives.
/// Units: millimetres and radians everywhere (DESIGN.md "Frames and units").

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace mlp::geometry {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
/// 2 x N matrix, one point per column [mm].
using Points2 = Eigen::Matrix2Xd;
/// 3 x N matrix, one point per column [mm].
using Points3 = Eigen::Matrix3Xd;
/// A rigid transform; name variables target_from_source (e.g. mcs_from_work).
using Pose3 = Eigen::Isometry3d;

/// Infinite line in 2D: a point on it and a unit direction.
struct Line2 {
  Vec2 point = Vec2::Zero();
  Vec2 direction = Vec2::UnitX();
};

/// Infinite line in 3D: a point on it and a unit direction.
struct Line3 {
  Vec3 point = Vec3::Zero();
  Vec3 direction = Vec3::UnitX();
};

/// Plane through `point` with unit `normal`.
struct Plane {
  Vec3 point = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
};

/// Circle in 2D.
struct Circle2 {
  Vec2 center = Vec2::Zero();
  double radius = 0.0;
};

/// Circle in 3D: centre, unit normal of its plane, radius.
struct Circle3 {
  Vec3 center = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  double radius = 0.0;
};

struct Sphere {
  Vec3 center = Vec3::Zero();
  double radius = 0.0;
};

/// Cylinder: `point` on the axis, unit `axis`, radius.
struct Cylinder {
  Vec3 point = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double radius = 0.0;
};

/// Cone in NIST's parametrisation: `point` on the axis, unit `axis` pointing towards growing
/// radius, `half_angle` [rad] in (0, pi/2), and `distance` = orthogonal distance from `point` to
/// the surface [mm] (radius at `point` = distance / cos(half_angle)).
struct Cone {
  Vec3 point = Vec3::Zero();
  Vec3 axis = Vec3::UnitZ();
  double half_angle = 0.0;
  double distance = 0.0;
  /// Apex position; far away for a nearly cylindrical cone.
  Vec3 Apex() const;
  /// Radius of the cone at `point` [mm].
  double RadiusAtPoint() const;
};

/// Ellipse in 2D: centre, rotation of the major axis from +x [rad], semi-axes a >= b [mm].
struct Ellipse2 {
  Vec2 center = Vec2::Zero();
  double angle = 0.0;
  double semi_major = 0.0;
  double semi_minor = 0.0;
};

/// Planar ellipse in 3D: centre, unit plane normal, unit major-axis direction, semi-axes.
struct Ellipse3 {
  Vec3 center = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();
  Vec3 major_axis = Vec3::UnitX();
  double semi_major = 0.0;
  double semi_minor = 0.0;
};

}  // namespace mlp::geometry
