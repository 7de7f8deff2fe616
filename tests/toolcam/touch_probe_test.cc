// A touch probe's trigger against the tool camera (seed 000 Fig. 6/7): the idle stylus' ball
// from its silhouette, the glass block's face with the probe stopped at its trigger, the
// pretravel and the length a probing cycle must use, against the virtual camera's truth.

#include "mlp/toolcam/touch_probe.h"

#include <cstdio>
#include <optional>
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

// Where the stylus stands in a frame: the camera that draws it `ball_y_mm` across from where the
// calibration has the spindle, the block's side face (fixed to the machine) at `face_y_mm`.
ToolCameraModel DrawnAt(double ball_y_mm, std::optional<double> face_y_mm) {
  ToolCameraModel c = StylusCamera();
  c.axis_u_px += ball_y_mm / c.mm_per_px;
  if (face_y_mm) c.glass_side_y_mm = *face_y_mm - ball_y_mm;
  return c;
}

// Sideways: the ball 2 um off the spindle axis; moved across against a side face of the block,
// the probe triggers 6 um after touching on the +y side and 4 um on the -y side (the pivot's
// lobes). The face's distance from the idle ball's centre is r less the pretravel, and the
// faces' distance the diameter a probing cycle uses, free of the ball's offset.
TEST(TouchProbe, TheLateralTriggerIsTheEffectiveRadius) {
  const ToolDescription probe = LoadTool(kStylus);
  const double r = probe.Radius(), offset = 0.002, plus = 0.006, minus = 0.004;
  const ToolCameraModel calibrated = StylusCamera();
  const StylusSeen idle =
      MeasureStylus(Frames(probe, DrawnAt(offset, std::nullopt), 66), calibrated, probe);
  // At the trigger the ball rests on the face, pushed back by the pretravel.
  const double face_plus = offset + r - plus, face_minus = offset - r + minus;
  const LateralTrigger p = CalibrateLateralTrigger(
      idle, Frames(probe, DrawnAt(face_plus - r, face_plus), 67), calibrated, probe);
  const LateralTrigger m = CalibrateLateralTrigger(
      idle, Frames(probe, DrawnAt(face_minus + r, face_minus), 68), calibrated, probe);
  const double diameter = EffectiveDiameter({p, m});
  std::printf(
      "lateral trigger: ball centre %+.2f um (true %+.2f); +y face %.5f mm, pretravel %.2f um "
      "(true 6.00), effective radius %.5f; -y face %.5f mm, pretravel %.2f um (true 4.00); "
      "effective diameter %.5f mm (true %.5f)\n",
      idle.centre_y_mm * 1e3, offset * 1e3, p.face_y_mm, p.pretravel_mm * 1e3,
      p.effective_radius_mm, m.face_y_mm, m.pretravel_mm * 1e3, diameter, 2 * r - plus - minus);
  EXPECT_NEAR(idle.centre_y_mm, offset, kBallTolMm);
  EXPECT_EQ(p.side, 1);
  EXPECT_EQ(m.side, -1);
  EXPECT_NEAR(p.face_y_mm, face_plus, kPretravelTolMm);
  EXPECT_NEAR(m.face_y_mm, face_minus, kPretravelTolMm);
  EXPECT_NEAR(p.pretravel_mm, plus, kPretravelTolMm);
  EXPECT_NEAR(m.pretravel_mm, minus, kPretravelTolMm);
  EXPECT_NEAR(p.effective_radius_mm, r - plus, kPretravelTolMm);
  EXPECT_NEAR(diameter, 2 * r - plus - minus, 2 * kPretravelTolMm);
  EXPECT_NEAR(EffectiveDiameter({p}), 2 * (r - plus), 2 * kPretravelTolMm);
  // No side face in the trigger frames; two faces on one side; none.
  EXPECT_THROW(CalibrateLateralTrigger(idle, Frames(probe, DrawnAt(offset, std::nullopt), 69),
                                       calibrated, probe),
               ToolError);
  EXPECT_THROW(EffectiveDiameter({p, p}), ToolInputError);
  EXPECT_THROW(EffectiveDiameter({}), ToolInputError);
}

}  // namespace
}  // namespace mlp::toolcam
