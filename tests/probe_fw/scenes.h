#pragma once
// Scenes the firmware tests look at: the flat face (a box whose top, z = 0 in the MCS, is seen
// from 120 mm, the probe looking down and tilted 0.05 rad about y) and the captures into a bore.

#include "mlp/sim/render.h"
#include "mlp/sim/scene.h"

#include <cmath>
#include <string>

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

// A capture looking into a bore on the z axis at its wall sector at angle theta + 180 deg, 12 mm
// down, from 120 mm, the camera tilted 30 deg from the bore axis (the probe's mounting on a
// 3-axis machine; the spindle's orientation turns it around the bore). Camera x points towards
// the projector.
inline Capture WallCapture(double theta_rad, double radius_mm, const std::string& id) {
  const Vec3 radial(std::cos(theta_rad), std::sin(theta_rad), 0.0);
  const Vec3 wall = -radius_mm * radial + Vec3(0, 0, -12.0);
  const double tilt = 30.0 * M_PI / 180.0;
  const Vec3 z_cam = (-std::sin(tilt) * radial - std::cos(tilt) * Vec3::UnitZ()).normalized();
  const Vec3 x_cam = (std::cos(tilt) * radial - std::sin(tilt) * Vec3::UnitZ()).normalized();
  Capture c;
  c.id = id;
  c.mcs_from_flange.linear() << x_cam, z_cam.cross(x_cam), z_cam;
  c.mcs_from_flange.translation() = wall - 120.0 * z_cam;
  return c;
}

// The sweep of a wall capture: a 300 x 200 px AOI, every second column reaching it.
inline SweepOptions WallSweep(const VirtualProbe& probe, const Capture& capture) {
  SweepOptions o;
  o.aoi = {874, 668, 300, 200};
  probe.ColumnsReaching(capture, o.aoi, &o.first_column, &o.last_column);
  o.column_step = 2.0;
  o.seed = 7;
  return o;
}

}  // namespace mlp::sim::testing
