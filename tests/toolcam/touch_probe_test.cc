// A touch probe's trigger against the tool camera (seed 000 Fig. 6/7): the idle stylus' ball
// from its silhouette, the glass block's face with the probe stopped at its trigger, the
// pretravel and the length a probing cycle must use, against the virtual camera's truth.

#include "mlp/toolcam/touch_probe.h"

#include <cstdio>
#include <random>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

const std::string kStylus = mlp::test::SourceDir() + "/samples/tools/stylus_d2.json";
constexpr double kBallTolMm = 0.0005;       // the ball's radius and bottom from 4 frames
constexpr double kPretravelTolMm = 0.0005;  // the face against the ball's bottom

// The D2 ball in the middle of a 640 x 560 px field (2.56 x 2.24 mm), its bottom 60 px above
// the image's bottom, the camera turned 0.3 deg about x.
ToolCameraModel StylusCamera() {
  ToolCameraModel c;
  c.width_px = 640, c.height_px = 560;
  c.axis_u_px = 319.5, c.tip_v_px = 500, c.roll_deg = 0.3, c.drops_per_frame = 0;
  return c;
}

std::vector<std::vector<std::uint8_t>> Frames(const ToolDescription& t,
                                              const ToolCameraModel& c,
                                              unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<std::uint8_t>> frames;
  for (int k = 0; k < 4; ++k) frames.push_back(RenderToolFrame(t, c, k * 0.5, 0, rng).pixels);
  return frames;
}

// The probe runs 3 um off its nominal length (its ball lower) and triggers 8 um after touching:
// the face stands 8 um above where the undeflected ball's bottom would be, and the length a
// probing cycle uses is the idle one less that.
TEST(TouchProbe, TheTriggerIsThePretravelAboveTheIdleBall) {
  ToolDescription probe = LoadTool(kStylus);
  const ToolDescription nominal = probe;
  probe.edges[0].axial_offset_mm = 0.003;  // 60.003 mm to the ball's bottom
  const double pretravel = 0.008;
  const ToolCameraModel idle_camera = StylusCamera();
  // At the trigger the ball rests on the face: lifted by the pretravel from where the spindle
  // holds it, the face where it rests.
  ToolDescription deflected = probe;
  deflected.edges[0].axial_offset_mm -= pretravel;
  ToolCameraModel trigger_camera = StylusCamera();
  trigger_camera.glass_face_h_mm = deflected.TipH(0);
  const TriggerCalibration t =
      CalibrateTrigger(Frames(probe, idle_camera, 61), idle_camera,
                       Frames(deflected, trigger_camera, 62), trigger_camera, nominal);
  std::printf(
      "stylus: ball D %.5f mm (true 2), bottom %+.2f um (true -3.00), rms %.2f um over %d points; "
      "face %+.2f um; pretravel %.2f um (true 8.00); lengths idle %.5f, trigger %.5f mm\n",
      t.ball_diameter_mm, (t.idle.centre_h_mm - t.idle.radius_mm) * 1e3, t.idle.rms_mm * 1e3,
      t.idle.points, t.face_h_mm * 1e3, t.pretravel_mm * 1e3, t.idle_length_mm,
      t.trigger_length_mm);
  EXPECT_NEAR(t.ball_diameter_mm, 2.0, 2 * kBallTolMm);
  EXPECT_NEAR(t.idle.centre_y_mm, 0.0, kBallTolMm);
  EXPECT_NEAR(t.idle_length_mm, 60.003, kBallTolMm);
  EXPECT_NEAR(t.pretravel_mm, pretravel, kPretravelTolMm);
  EXPECT_NEAR(t.trigger_length_mm, 60.003 - pretravel, kPretravelTolMm);
  // The block not in view at the trigger, or a cutter given as the stylus: said, not guessed.
  EXPECT_THROW(CalibrateTrigger(Frames(probe, idle_camera, 63), idle_camera,
                                Frames(probe, idle_camera, 64), idle_camera, nominal),
               ToolError);
  EXPECT_THROW(
      MeasureStylus(Frames(probe, idle_camera, 65), idle_camera,
                    LoadTool(mlp::test::SourceDir() + "/samples/tools/drill_d1.5_118.json")),
      ToolInputError);
}

}  // namespace
}  // namespace mlp::toolcam
