#pragma once
/// @file A straight part edge as the probe's camera saw it on the LED frame (seed 004's edge
/// ROI): the plane through the camera centre that holds the edge (its "interpretation plane"),
/// and the rays to the first and last edge points found along it. The probe frame is the
/// camera's optical frame, so the plane passes through the probe frame's origin. The host
/// meets it with a measured face to get the edge in 3D (docs/HOSTD.md). One type and one serial
/// form for the link's CLOUD payload and the cloud file's comment (docs/LINK.md).

#include <array>
#include <cmath>
#include <cstdint>
#include <string>

#include <Eigen/Core>

namespace mlp::base {

struct EdgeSight {
  /// Unit normal of the plane through the camera centre and the edge [probe frame]; the lit
  /// face (the bright side of the edge in the LED frame) is on its positive side.
  Eigen::Vector3d normal_in_probe = Eigen::Vector3d::UnitX();
  /// Unit rays from the camera centre to the ends of the edge points, in the plane [probe frame].
  Eigen::Vector3d first_ray_in_probe = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d last_ray_in_probe = Eigen::Vector3d::UnitZ();
  double rms_px = 0.0;       ///< edge points about their straight line [sensor px]
  std::uint32_t points = 0;  ///< edge points on the line
};

/// Edge points on one line at most: one per sensor row or column along it, and the link's AOI
/// is 16-bit. A count of 0xFFFFFFFF became -1 as an int further on and failed every later job
/// on that capture.
constexpr std::uint32_t kMaxEdgePoints = 65535;

/// The numbers of a sight in their serial order: normal, first ray, last ray, rms.
inline std::array<double, 10> EdgeSightNumbers(const EdgeSight& s) {
  std::array<double, 10> v{};
  for (std::size_t i = 0; i < 3; ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    v[i] = s.normal_in_probe(k);
    v[3 + i] = s.first_ray_in_probe(k);
    v[6 + i] = s.last_ray_in_probe(k);
  }
  v[9] = s.rms_px;
  return v;
}

/// A sight from its serial numbers and point count; false and the reason in `why` when they
/// are not one: a number not finite, a vector not of unit length (to 1e-6), a ray not in front
/// of the camera or off the plane (to 1e-6), a negative rms, fewer than 2 points or more than
/// kMaxEdgePoints.
inline bool EdgeSightFromNumbers(const std::array<double, 10>& v,
                                 std::uint32_t points,
                                 EdgeSight* sight,
                                 std::string* why) {
  for (double x : v) {
    if (!std::isfinite(x)) return *why = "the edge holds a non-finite number", false;
  }
  EdgeSight s;
  s.normal_in_probe = Eigen::Vector3d(v[0], v[1], v[2]);
  s.first_ray_in_probe = Eigen::Vector3d(v[3], v[4], v[5]);
  s.last_ray_in_probe = Eigen::Vector3d(v[6], v[7], v[8]);
  s.rms_px = v[9];
  s.points = points;
  constexpr double kUnitTol = 1e-6;
  for (const Eigen::Vector3d* u :
       {&s.normal_in_probe, &s.first_ray_in_probe, &s.last_ray_in_probe}) {
    if (!(std::abs(u->norm() - 1.0) <= kUnitTol))
      return *why = "an edge vector is not of unit length", false;
  }
  for (const Eigen::Vector3d* r : {&s.first_ray_in_probe, &s.last_ray_in_probe}) {
    if (!(r->z() > 0.0)) return *why = "an edge ray points behind the camera", false;
    if (!(std::abs(r->dot(s.normal_in_probe)) <= kUnitTol))
      return *why = "an edge ray is off the edge's plane", false;
  }
  if (!(s.rms_px >= 0.0)) return *why = "the edge's rms is negative", false;
  if (points < 2) return *why = "the edge has fewer than 2 points", false;
  if (points > kMaxEdgePoints)
    return *why = "the edge has more than " + std::to_string(kMaxEdgePoints) + " points", false;
  *sight = s;
  return true;
}

}  // namespace mlp::base
