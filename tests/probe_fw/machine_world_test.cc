// The virtual machine's trunnion (sim/machine_world.h) against hand-computed poses, and its file.

#include "mlp/sim/machine_world.h"

#include "mlp/sim/scene.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

using geometry::Vec3;
constexpr double kTolMm = 1e-9;

// A on X through (y, z) = (-40, -90), C on Z through (120, -40), both exact.
TrunnionWorld Square() {
  TrunnionWorld w;
  w.a = {Vec3(0, -40, -90), Vec3::UnitX()};
  w.c = {Vec3(120, -40, 0), Vec3::UnitZ()};
  return w;
}

TEST(TrunnionWorld, AtZeroTheTableIsTheMachine) {
  const geometry::Pose3 h = Square().TableFromFlange({Vec3(10, 20, 30), 0, 0, 90});
  EXPECT_NEAR((h.translation() - Vec3(10, 20, 30)).norm(), 0, kTolMm);
  // z along the tool (down), x along machine Y once the spindle is oriented to 90 deg.
  EXPECT_NEAR((h.linear().col(2) - Vec3(0, 0, -1)).norm(), 0, 1e-12);
  EXPECT_NEAR((h.linear().col(0) - Vec3(0, 1, 0)).norm(), 0, 1e-12);
}

TEST(TrunnionWorld, TheFlangeSeenFromATurnedAndTiltedTable) {
  // C +90: a table point at (x, y) sits at C's centre + Rz(90) (x - 120, y + 40). A +90 about
  // +X through (y, z) = (-40, -90): (y, z) -> (-40 - (z + 90), -90 + (y + 40)). Inverted by
  // hand for the gauge point (120, -40, 10): back through A: y = -40 + (10 + 90) = 60, z = -90
  // - (-40 + 40) = -90, so (120, 60, -90) at C +90; back through C: (120 + 100, -40, -90).
  const geometry::Pose3 h = Square().TableFromFlange({Vec3(120, -40, 10), 90, 90, 0});
  EXPECT_NEAR((h.translation() - Vec3(220, -40, -90)).norm(), 0, kTolMm);
  // The tool (machine -Z) seen from the table: back through A +90 it is -Y... then C -90 turns
  // -Y into -X.
  EXPECT_NEAR((h.linear().col(2) - Vec3(-1, 0, 0)).norm(), 0, 1e-12);
}

TEST(TrunnionWorld, ReadsItsFileAndRefusesAnythingElse) {
  const TrunnionWorld w = ParseTrunnionWorld(R"({"format": "mlprobe-machine/1",
      "kind": "trunnion", "a_axis": {"point_mm": [0, -37.5, -90], "direction": [1, 0.0002, 0]},
      "c_axis": {"point_mm": [120.03, -40, 0], "direction": [0, 0, 1]}})");
  EXPECT_NEAR(w.a.direction.norm(), 1.0, 1e-15);
  EXPECT_NEAR(w.c.point.x(), 120.03, 1e-12);
  EXPECT_EQ(w.joint_pins[3], "joint.3.pos-fb");
  for (const char* bad :
       {R"({"format": "mlprobe-machine/1", "kind": "head", "a_axis": {}, "c_axis": {}})",
        R"({"format": "mlprobe-machine/1", "kind": "trunnion",
            "a_axis": {"point_mm": [0, 0, 0], "direction": [0, 0, 0]},
            "c_axis": {"point_mm": [0, 0, 0], "direction": [0, 0, 1]}})",
        R"({"format": "mlprobe-machine/1", "kind": "trunnion", "a_axs": {}})",
        R"({"format": "mlprobe-machine/1", "kind": "trunnion",
            "a_axis": {"point_mm": [0, 0, 0], "direction": [1, 0, 0]},
            "c_axis": {"point_mm": [0, 0, 0], "direction": [0, 0, 1]}, "joint_pins": ["x"]})",
        "[1, 2]", "not json"})
    EXPECT_THROW(ParseTrunnionWorld(bad), SceneError) << bad;
}

}  // namespace
}  // namespace mlp::sim
