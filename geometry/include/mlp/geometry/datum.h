#pragma once
/// @file Datum reference frames (ISO 5459) from fitted elements, and their reading as a work
/// offset. All poses are target_from_source: `mcs_from_work` maps work coordinates to machine
/// coordinates; its translation is the work origin in the machine frame.

#include "mlp/geometry/types.h"

namespace mlp::geometry {

/// 3-2-1 alignment: primary plane -> Z (its normal), secondary line -> X (its direction
/// projected on the plane, oriented by the line's direction), tertiary point -> the origin's X
/// position. The origin lies on the primary plane, on the plane through the secondary line
/// perpendicular to the primary, and on the plane through the tertiary point perpendicular to X.
/// Throws GeometryError(kDegenerate) when the line is (nearly) perpendicular to the plane.
Pose3 DatumPlaneLinePoint(const Plane& primary, const Line3& secondary, const Vec3& tertiary);

/// Seed 004 example: plane A with holes B and C. Origin = centre of B projected on A, Z = normal
/// of A, Y = B -> C projected on A, X = Y x Z. Throws kDegenerate when B and C coincide in
/// projection.
Pose3 DatumPlaneCircleCircle(const Plane& a, const Vec3& center_b, const Vec3& center_c);

/// A pose read the way a controller's work offset holds it.
struct WorkOffsetReading {
  Vec3 origin_mm = Vec3::Zero();      ///< G54-style X, Y, Z: the work origin in machine coordinates
  double rotation_z_deg = 0.0;        ///< rotation of the work X axis about machine Z (G68 / G54.4)
  double tilt_deg = 0.0;              ///< angle between work Z and machine Z (0 for a level part)
  Vec3 euler_zyx_deg = Vec3::Zero();  ///< full rotation R = Rz(c) Ry(b) Rx(a) as (a, b, c)
};

/// Reads `mcs_from_work` as a work offset.
WorkOffsetReading ReadWorkOffset(const Pose3& mcs_from_work);

/// Maps every column of `points_in_source` by `target_from_source`.
Points3 TransformPoints(const Pose3& target_from_source, const Points3& points_in_source);

}  // namespace mlp::geometry
