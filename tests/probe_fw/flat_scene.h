#pragma once
// The flat face the firmware tests look at: a box whose top (z = 0 in the MCS) is seen from
// 120 mm, the probe looking down and tilted 0.05 rad about y.

#include "mlp/sim/scene.h"

#include <cmath>

#include <Eigen/Geometry>

namespace mlp::sim::testing {

inline Scene FlatScene(double reflectance, double half_width_mm) {
  Scene s;
  s.workpiece = MakeBox({-half_width_mm, -half_width_mm, -30}, {half_width_mm, half_width_mm, 0},
                        reflectance);
  Capture c;
  c.id = "top";
  c.mcs_from_flange = Pose3::Identity();
  c.mcs_from_flange.translation() = Vec3(0.3, -0.2, 120.0);
  c.mcs_from_flange.linear() =
      (Eigen::AngleAxisd(M_PI, Vec3::UnitX()) * Eigen::AngleAxisd(0.05, Vec3::UnitY()))
          .toRotationMatrix();
  s.captures.push_back(c);
  return s;
}

}  // namespace mlp::sim::testing
