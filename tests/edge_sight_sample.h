#pragma once
// A valid straight edge as the firmware reports it from an LED frame (rays in the edge's plane,
// which passes through the probe's origin, ahead of the probe): for the link's tests.

#include "mlp/base/edge_sight.h"

#include <cstdint>

#include <Eigen/Geometry>

namespace mlp::test {

inline base::EdgeSight SampleEdgeSight(std::uint32_t points = 233) {
  base::EdgeSight e;
  e.normal_in_probe = Eigen::Vector3d(0.0, 0.9995, -0.0316).normalized();
  const Eigen::Vector3d down = e.normal_in_probe.cross(Eigen::Vector3d::UnitX()).normalized();
  const Eigen::Vector3d ahead = down.z() > 0 ? down : Eigen::Vector3d(-down);
  e.first_ray_in_probe = (ahead - 0.012 * Eigen::Vector3d::UnitX()).normalized();
  e.last_ray_in_probe = (ahead + 0.012 * Eigen::Vector3d::UnitX()).normalized();
  e.rms_px = 0.0625;
  e.points = points;
  return e;
}

}  // namespace mlp::test
