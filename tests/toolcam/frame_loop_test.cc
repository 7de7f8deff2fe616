// Seed 000's frame loop: the pin's calibration is the loop it closes (the camera through it is
// the one the pin measured), the encoders move the tool round it, the part change that closes
// it again is the 2 x 2 system's answer, and a machine whose y travel is not square to the
// spindle is measured right only when the loop knows it.

#include "mlp/toolcam/frame_loop.h"

#include "mlp/toolcam/pin_calibration.h"

#include <cmath>
#include <cstdio>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

constexpr double kExactPx = 1e-9;   // one formula against another
constexpr double kExactMm = 1e-12;  // a linear system solved back
constexpr double kEdgeTolMm = 0.001;

Pose3 Turned(double about_x_deg, double about_z_deg, const Vec3& at) {
  Pose3 p = Pose3::Identity();
  p.linear() = (Eigen::AngleAxisd(about_z_deg * M_PI / 180, Vec3::UnitZ()) *
                Eigen::AngleAxisd(about_x_deg * M_PI / 180, Vec3::UnitX()))
                   .toRotationMatrix();
  p.translation() = at;
  return p;
}

// The camera through the pin's loop is the closed form the calibration always used: the tip
// (shift_y, shift_z - length) from the gauge point, turned by the roll.
TEST(FrameLoop, ThePinsLoopIsTheCameraItMeasured) {
  PinCalibration p;
  p.mm_per_px = 0.004, p.roll_deg = -0.3, p.pitch_deg = 0.03;
  p.gauge_u_px = 505.7, p.gauge_v_px = -12099.4;
  ToolCameraModel base;
  const ToolCameraModel c = p.CameraFor(base, 75.0, -4.0, 24.4);
  const double a = p.roll_deg * M_PI / 180, dz = 24.4 - 75.0;
  EXPECT_NEAR(c.axis_u_px, p.gauge_u_px + (std::cos(a) * -4.0 - std::sin(a) * dz) / 0.004,
              kExactPx);
  EXPECT_NEAR(c.tip_v_px, p.gauge_v_px - (std::sin(a) * -4.0 + std::cos(a) * dz) / 0.004, kExactPx);
  EXPECT_NEAR(c.roll_deg, -0.3, kExactPx);
  EXPECT_EQ(c.pitch_deg, 0.03);
}

// A detector turned 30 deg about its view and 20 deg about the vertical, the encoders moved:
// the model moved by (dy, dz) on the tool shows as an image shift the 2 x 2 system turns back
// into (dy, dz); the loop's gap is the change's image before, and none after.
TEST(FrameLoop, TheAllowedChangeClosesTheLoop) {
  FrameLoop loop;
  loop.structure_from_detector = Turned(30, 20, Vec3(-80, 12, 300));
  loop.structure_from_support = Turned(0, 0, Vec3(0, 5, 400));
  loop.tool_length_mm = 62.5, loop.encoder_y_mm = -3.25, loop.encoder_z_mm = 17.0;
  const Vec2 change(0.0123, -0.0047);
  FrameLoop moved = loop;
  moved.model_change_mm = change;
  const Vec3 before = loop.DetectorFromModel().translation();
  const Vec3 after = moved.DetectorFromModel().translation();
  const Vec2 shift(after.y() - before.y(), after.z() - before.z());
  const Vec2 solved = AllowedChange(loop, shift);
  EXPECT_NEAR(solved.x(), change.x(), kExactMm);
  EXPECT_NEAR(solved.y(), change.y(), kExactMm);
  ToolCameraModel base;
  base.mm_per_px = 0.004;
  const ToolCameraModel seen = CameraThroughLoop(moved, base);
  EXPECT_NEAR(LoopGapMm(loop, base, {seen.axis_u_px, seen.tip_v_px}), shift.norm(), kExactMm);
  FrameLoop closed = loop;
  closed.model_change_mm = solved;
  EXPECT_NEAR(LoopGapMm(closed, base, {seen.axis_u_px, seen.tip_v_px}), 0.0, kExactMm);
  // Turned 90 deg about the vertical, the tool's y runs along the view: no answer.
  FrameLoop edge_on = loop;
  edge_on.structure_from_detector = Turned(0, 90, Vec3::Zero());
  EXPECT_THROW(AllowedChange(edge_on, shift), ToolInputError);
}

// The machine's y travel 0.1 deg out of square with the spindle (it rises 1.75 um a mm): the
// tool measured 10 mm across from the calibration's place. The loop that knows the travel
// puts the tool's tip where it is and its length comes out right; the square loop misses it
// by the 17.5 um the travel rose.
TEST(FrameLoop, EncodersEnterTheLoopAndAMachineOutOfSquareIsMeasuredThroughIt) {
  const ToolDescription tool =
      LoadTool(mlp::test::SourceDir() + "/samples/tools/endmill_d10_z4_new.json");
  ToolCameraModel base;
  base.width_px = 400, base.height_px = 600, base.drops_per_frame = 0;
  FrameLoop truth;  // the detector placed to show the +y flank of the tool 10 mm across
  truth.structure_from_detector = Turned(0, 0, Vec3(0, 200 * 0.004 - 15.0, -(-18230.0) * 0.004));
  truth.structure_from_detector = truth.structure_from_detector.inverse();
  truth.tool_length_mm = 75.0, truth.encoder_y_mm = 10.0;
  const double tilt = 0.1 * M_PI / 180;
  truth.carriage_travel = Vec3(0, std::cos(tilt), std::sin(tilt));
  const ToolCameraModel rendered = CameraThroughLoop(truth, base);
  FrameLoop square = truth;
  square.carriage_travel = Vec3::UnitY();
  const ToolCameraModel naive = CameraThroughLoop(square, base);
  std::printf("tip row through the loop %.3f px, square %.3f px (%.2f um)\n", rendered.tip_v_px,
              naive.tip_v_px, (naive.tip_v_px - rendered.tip_v_px) * base.mm_per_px * 1e3);
  const test::RenderedSeries s = test::RenderSeries(tool, rendered, 48);
  const ToolMeasurement known =
      MeasureTool(s.frames, s.positions, s.position_count, tool, rendered);
  const ToolMeasurement missed = MeasureTool(s.frames, s.positions, s.position_count, tool, naive);
  std::printf("length off: loop %+.2f um, square %+.2f um\n", known.tip_h_mm * 1e3,
              missed.tip_h_mm * 1e3);
  EXPECT_NEAR(known.tip_h_mm, 0.0, kEdgeTolMm);
  EXPECT_NEAR(known.radius_mm, 5.0, kEdgeTolMm);
  EXPECT_NEAR(missed.tip_h_mm, 10.0 * std::sin(tilt), kEdgeTolMm);  // read as 17 um short
}

}  // namespace
}  // namespace mlp::toolcam
