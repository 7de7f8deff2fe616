#pragma once
/// @file The machine the virtual probe rides on, as it truly is (issue 54): a trunnion whose A
/// axis tilts a rotary table C, its two centre lines where they really are (not where the
/// controller's parameters say), and the scene fixed to the C table. Given the joints the
/// controller reports, it places the probe in the scene's frame (the table's) as the physical
/// machine would. Written apart from calib/trunnion.h (the method under test) on purpose: the
/// virtual world shares no code with the estimate it judges; both follow LinuxCNC's
/// xyzac-trt-kins (C turns first, riding on the cradle; A turns both; right-handed about each
/// axis' direction), which tests/host/linuxcnc_trunnion_test.cc checks against the controller.

#include "mlp/geometry/types.h"

#include <array>
#include <string>

namespace mlp::sim {

/// A rotary axis' centre line at A = C = 0 in the machine frame.
struct RotaryLine {
  geometry::Vec3 point = geometry::Vec3::Zero();
  geometry::Vec3 direction = geometry::Vec3::UnitZ();  ///< unit; the positive turn about it
};

/// The joints of a capture as the controller holds them at rest.
struct TrunnionJoints {
  geometry::Vec3 gauge_machine_mm = geometry::Vec3::Zero();  ///< joints X, Y, Z
  double a_deg = 0.0, c_deg = 0.0;
  double spindle_deg = 0.0;  ///< the spindle's orientation (M19), about machine Z
};

struct TrunnionWorld {
  RotaryLine a{geometry::Vec3::Zero(), geometry::Vec3::UnitX()};
  RotaryLine c{geometry::Vec3::Zero(), geometry::Vec3::UnitZ()};
  /// The HAL pins the joints are read from: X, Y, Z, A, C and the spindle's orientation.
  std::array<std::string, 6> joint_pins{"joint.0.pos-fb", "joint.1.pos-fb",
                                        "joint.2.pos-fb", "joint.3.pos-fb",
                                        "joint.4.pos-fb", "spindle.0.orient-angle"};

  /// The flange in the table's frame: the flange frame T(x, y, z) Rz(spindle) Rx(180 deg) in
  /// the machine frame (z along the tool, out of the spindle), carried back by the table's
  /// true motion at (a, c).
  geometry::Pose3 TableFromFlange(const TrunnionJoints& joints) const;
};

/// A machine file (docs/SCENE.md, "The machine"): {"format": "mlprobe-machine/1", "kind":
/// "trunnion", "a_axis": {"point_mm", "direction"}, "c_axis": {...}, "joint_pins" (optional,
/// six names)}. Throws SceneError on anything else.
TrunnionWorld ParseTrunnionWorld(const std::string& json_text);
TrunnionWorld LoadTrunnionWorld(const std::string& path);

}  // namespace mlp::sim
