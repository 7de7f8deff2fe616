// Tools measured from the virtual tool camera's frames against its truth: each edge's radius
// and tip, the tool's effective radius and length, runout; with coolant drops; chipped and
// built-up edges found where they are. A smaller image than the default (400 x 600 px round
// the corner) keeps each run to a fraction of a second.

#include "mlp/toolcam/measure.h"

#include "mlp/toolcam/pin_calibration.h"

#include <cmath>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

const std::string kTools = mlp::test::SourceDir() + "/samples/tools/";
constexpr double kCleanTolMm = 0.001;         // issue 7: radius and length within 1 um, clean tool
constexpr double kDropsTolMm = 0.002;         // and within 2 um with coolant drops
constexpr double kPitchTolDeg = 0.005;        // 0.09 um per mm of depth
constexpr double kFindingHeightTolMm = 0.03;  // where a wear or build-up finding sits
constexpr double kFindingDepthTolMm = 0.002;  // how deep it is
constexpr double kScaleTol = 2e-5;            // 20 ppm: 1 um over the 50 mm pin
constexpr double kEndAcrossTolPx = 0.05;      // the pin's end across the axis
constexpr double kAlongTolPx = 0.25;          // along the axis: 1 um
constexpr double kGaugeAcrossTolPx = 1.0;     // 50 mm up an axis known to 0.002 deg: 1.7 um
constexpr double kRollTolDeg = 0.002;
constexpr double kDistortionTol = 3e-5;       // k1: 0.02 px at the corner of a 1024 x 768 image
constexpr double kCornerWearFoundMm = 0.010;  // an R 0.04 corner's stretch off a square model

ToolCameraModel SmallCamera(double drops) {
  ToolCameraModel c;
  c.width_px = 400, c.height_px = 600;
  c.axis_u_px = 200 - 5.0 / c.mm_per_px;  // the edge (R 5) in the middle of the image
  c.tip_v_px = 520;                       // the tip 80 px above the bottom: h up to 2.1 mm
  c.drops_per_frame = drops;
  return c;
}

using test::EdgeFacing;
using test::MeasuredRun;

MeasuredRun RenderAndMeasure(const ToolDescription& tool,
                             const ToolDescription& nominal,
                             const ToolCameraModel& c,
                             unsigned seed,
                             double resolution_deg = 7.2) {
  test::RunSetup setup;
  setup.resolution_deg = resolution_deg;
  return test::RenderAndMeasure(tool, nominal, c, seed, setup);
}

void ExpectEdgesMatch(const ToolDescription& t, const MeasuredRun& run, double tol_mm) {
  ASSERT_EQ(run.m.flutes.size(), static_cast<size_t>(t.flutes));
  for (const FluteMeasurement& f : run.m.flutes) {
    const int k = EdgeFacing(t, run.turn[static_cast<size_t>(f.plus.frame)], 1.5);
    const double r_true = t.Radius() + t.edges[static_cast<size_t>(k)].radial_offset_mm;
    std::printf(
        "  edge %d: radius %.4f (true %.4f, %+.2f um), tip %+.2f um (true %+.2f), rms %.2f um, "
        "%d points, %d removed\n",
        k + 1, f.radius_mm, r_true, (f.radius_mm - r_true) * 1e3, f.tip_h_mm * 1e3, t.TipH(k) * 1e3,
        f.plus.rms_mm * 1e3, f.plus.points, f.plus.removed);
    EXPECT_NEAR(f.radius_mm, r_true, tol_mm) << "edge " << k + 1;
    EXPECT_NEAR(f.tip_h_mm, t.TipH(k), tol_mm) << "edge " << k + 1;
  }
}

TEST(ToolMeasure, ACleanToolsEdgesToAMicrometre) {
  const ToolDescription worn = LoadTool(kTools + "endmill_d10_z4_worn.json");
  ToolDescription runout = worn;  // its runout and lengths, without its defects
  for (auto& e : runout.edges) e.defects.clear();
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  const MeasuredRun run = RenderAndMeasure(runout, nominal, SmallCamera(0), 11);
  ExpectEdgesMatch(runout, run, kCleanTolMm);
  EXPECT_NEAR(run.m.radius_mm, 5.006, kCleanTolMm);      // edge 2 cuts the wall
  EXPECT_NEAR(run.m.tip_h_mm, -0.004, kCleanTolMm);      // and the floor
  EXPECT_NEAR(run.m.runout_mm, 0.009, 2 * kCleanTolMm);  // 5.006 - 4.997
  for (const auto& f : run.m.flutes)
    EXPECT_TRUE(f.plus.findings.empty()) << "a finding on a clean edge";
}

// A camera turned 0.4 deg about x and 0.3 deg about y (as its calibration says): the rolled
// pixels and the pitched view of the edges' ends are in the measurement's model, so the edges
// are where they were square on (uncorrected, the pitch alone would move an end facing the
// camera by R tan(0.3 deg) = 26 um).
TEST(ToolMeasure, AMountTurnedAboutXAndYIsMeasuredThroughItsCalibration) {
  const ToolDescription worn = LoadTool(kTools + "endmill_d10_z4_worn.json");
  ToolDescription runout = worn;
  for (auto& e : runout.edges) e.defects.clear();
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  ToolCameraModel c = SmallCamera(0);
  c.roll_deg = 0.4, c.pitch_deg = 0.3;
  const MeasuredRun run = RenderAndMeasure(runout, nominal, c, 13);
  ExpectEdgesMatch(runout, run, kCleanTolMm);
  for (const auto& f : run.m.flutes)
    EXPECT_TRUE(f.plus.findings.empty()) << "a finding on a clean edge";
}

// Issue 51: a square end's corner worn to R 0.04 (16.6 um in along the bisector) is found on
// every flute as corner wear, where the flank's and the end's stretches off the model were
// each too short to report; the same tool new shows nothing (the project's renderer).
TEST(ToolMeasure, AWornSquareCornerIsReported) {
  const std::string head = R"({"format": "mlprobe-tool/1", "id": "EM8", "diameter_mm": 8.0,
      "length_mm": 60.0, "flutes": 4, "helix_deg": 30, "flute_length_mm": 16.0)";
  const ToolDescription nominal = ParseTool(head + "}");
  const ToolDescription worn = ParseTool(head + R"(, "corner_radius_mm": 0.04})");
  ToolCameraModel c = SmallCamera(0);
  c.axis_u_px = 200 - 4.0 / c.mm_per_px;  // the edge (R 4) in the middle of the image
  const MeasuredRun used = RenderAndMeasure(worn, nominal, c, 51);
  for (const FluteMeasurement& f : used.m.flutes) {
    int corners = 0;
    for (const Finding* d : f.Findings()) {
      EXPECT_TRUE(d->corner && !d->buildup) << "edge " << f.edge << " h " << d->h_mm;
      corners += d->corner;
      EXPECT_GT(d->max_mm, kCornerWearFoundMm);
    }
    EXPECT_GE(corners, 1) << "edge " << f.edge;
  }
  const MeasuredRun fresh = RenderAndMeasure(nominal, nominal, c, 52);
  for (const FluteMeasurement& f : fresh.m.flutes) EXPECT_TRUE(f.Findings().empty());
}

TEST(ToolMeasure, CoolantDropsAreLeftOut) {
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  const MeasuredRun run = RenderAndMeasure(nominal, nominal, SmallCamera(3.0), 12);
  ExpectEdgesMatch(nominal, run, kDropsTolMm);
  for (const auto& f : run.m.flutes)
    EXPECT_TRUE(f.plus.findings.empty()) << "a drop taken for a finding";
}

TEST(ToolMeasure, FindsTheChipAndTheBuiltUpEdge) {
  const ToolDescription worn = LoadTool(kTools + "endmill_d10_z4_worn.json");
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  const MeasuredRun run = RenderAndMeasure(worn, nominal, SmallCamera(0), 13);
  ExpectEdgesMatch(worn, run, kCleanTolMm);
  int chips = 0, buildups = 0;
  for (const FluteMeasurement& f : run.m.flutes) {
    const int k = EdgeFacing(worn, run.turn[static_cast<size_t>(f.plus.frame)], 1.5);
    for (const Finding& d : f.plus.findings) {
      std::printf("  edge %d: %s at h %.3f mm, %.3f mm long, %.1f um deep\n", k + 1,
                  d.buildup ? "build-up" : "wear", d.h_mm, d.length_mm, d.max_mm * 1e3);
      const EdgeDefect& truth = worn.edges[static_cast<size_t>(k)].defects.at(0);
      EXPECT_EQ(d.buildup, truth.depth_mm < 0);
      EXPECT_NEAR(d.h_mm, truth.h_mm + truth.length_mm / 2, kFindingHeightTolMm);
      EXPECT_NEAR(d.max_mm, std::abs(truth.depth_mm), kFindingDepthTolMm);
      (d.buildup ? buildups : chips) += 1;
    }
  }
  EXPECT_EQ(chips, 1);
  EXPECT_EQ(buildups, 1);
}

// A measured tool stored as its reference: measured again against it, nothing is new; after
// a new chip on another edge, only that chip is found.
TEST(ToolMeasure, AStoredReferenceShowsOnlyWhatChanged) {
  const ToolDescription worn = LoadTool(kTools + "endmill_d10_z4_worn.json");
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  const MeasuredRun first = RenderAndMeasure(worn, nominal, SmallCamera(0), 21);
  const ToolDescription reference = ParseTool(ToJson(ReferenceFrom(nominal, first.m)));
  const MeasuredRun again = RenderAndMeasure(worn, reference, SmallCamera(0), 22);
  ExpectEdgesMatch(worn, again, kCleanTolMm);
  for (const FluteMeasurement& f : again.m.flutes) {
    EXPECT_GE(f.edge, 0);
    EXPECT_TRUE(f.plus.findings.empty()) << "edge " << f.edge + 1 << ": " << f.plus.findings.size();
  }
  ToolDescription chipped = worn;  // a new 12 um chip on edge 4 at h 1.0 mm
  chipped.edges[3].defects.push_back({1.0, 0.2, 0.012});
  const MeasuredRun later = RenderAndMeasure(chipped, reference, SmallCamera(0), 23);
  int found = 0;
  for (const FluteMeasurement& f : later.m.flutes)
    for (const Finding& d : f.plus.findings) {
      const int k = EdgeFacing(chipped, later.turn[static_cast<size_t>(f.plus.frame)], 1.5);
      std::printf("  new since the reference: edge %d %s at h %.3f mm, %.1f um\n", k + 1,
                  d.buildup ? "build-up" : "wear", d.h_mm, d.max_mm * 1e3);
      EXPECT_EQ(k, 3);
      EXPECT_FALSE(d.buildup);
      EXPECT_NEAR(d.h_mm, 1.1, kFindingHeightTolMm);
      EXPECT_NEAR(d.max_mm, 0.012, kFindingDepthTolMm);
      ++found;
    }
  EXPECT_EQ(found, 1);
}

// The camera against the machine from the calibration pin: scale, the spindle axis' column and
// roll, the gauge point's row, against the camera the pin was rendered with (turned 0.25 deg).
TEST(ToolCalibration, ThePinGivesScaleAxisRollAndGauge) {
  const ToolDescription pin = LoadTool(kTools + "calibration_pin_d3.json");
  ToolCameraModel c;  // the default lens (distortion 0.05 %, noise 2 grey levels)
  c.axis_u_px = 511.3, c.tip_v_px = 560.4, c.drops_per_frame = 0, c.roll_deg = 0.25;
  std::mt19937 rng(31);
  std::vector<std::vector<std::uint8_t>> frames;
  for (int k = 0; k < 3; ++k) frames.push_back(RenderToolFrame(pin, c, k, 0, rng).pixels);
  const PinCalibration p = CalibrateWithPin(frames, {0, 1, 2}, 6, c, pin);
  const geometry::Vec2 gauge = c.PixelFromTool({0, pin.length_mm});
  std::printf(
      "pin: scale %.7f mm/px (%+.1f ppm), end at %.3f px (%+.3f), gauge row %+.2f px (%+.2f "
      "um), roll %.4f deg (%+.4f), width rms %.3f px over %d rows, k1 %.6f\n",
      p.mm_per_px, (p.mm_per_px / c.mm_per_px - 1) * 1e6, p.end_u_px, p.end_u_px - c.axis_u_px,
      p.gauge_v_px - gauge.y(), (p.gauge_v_px - gauge.y()) * c.mm_per_px * 1e3, p.roll_deg,
      p.roll_deg - c.roll_deg, p.width_rms_px, p.rows, p.distortion_k1);
  EXPECT_NEAR(p.mm_per_px / c.mm_per_px, 1.0, kScaleTol);
  EXPECT_NEAR(p.end_u_px, c.axis_u_px, kEndAcrossTolPx);
  EXPECT_NEAR(p.gauge_v_px, gauge.y(), kAlongTolPx);
  EXPECT_NEAR(p.gauge_u_px, gauge.x(), kGaugeAcrossTolPx);
  EXPECT_NEAR(p.roll_deg, c.roll_deg, kRollTolDeg);
  EXPECT_FALSE(p.pitch_measured);
  ToolDescription cutter = pin;
  cutter.pin = false;
  EXPECT_THROW(CalibrateWithPin(frames, {0, 1, 2}, 6, c, cutter), ToolInputError);
}

// With the pin's blades (seed 000 example 4) the tilt about y as well: a camera turned 0.3 deg
// and pitched 0.12 deg, the pin shown at 36 positions round the turn. A tool of 80 mm measured
// through the calibration then sits where the camera puts it.
TEST(ToolCalibration, TheBladesGiveThePitch) {
  const ToolDescription pin = LoadTool(kTools + "calibration_pin_d3_blades.json");
  ToolCameraModel c;
  // The pin's end low enough for 350 rows of flank (the roll to 0.002 deg: the edges' sub-pixel
  // error, 0.003 px, changes with the flank's phase over the rows), the blades above the bottom.
  c.axis_u_px = 505.7, c.tip_v_px = 400.6, c.drops_per_frame = 0;
  c.roll_deg = -0.3, c.pitch_deg = 0.12;
  std::mt19937 rng(32);
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<int> positions;
  for (int k = 0; k < 36; ++k) {
    positions.push_back(k);
    frames.push_back(RenderToolFrame(pin, c, 0.4 + 2 * M_PI * k / 36, 0, rng).pixels);
  }
  const PinCalibration p = CalibrateWithPin(frames, positions, 36, c, pin);
  const geometry::Vec2 gauge = c.PixelFromTool({0, pin.length_mm});
  std::printf(
      "bladed pin: pitch %.4f deg (%+.4f) from %d images, blade ends rms %.3f um; roll %+.4f "
      "deg (%+.4f); end %+.3f px, %+.3f px; gauge row %+.2f px (%+.2f um)\n",
      p.pitch_deg, p.pitch_deg - c.pitch_deg, p.blade_images, p.blade_rms_um, p.roll_deg,
      p.roll_deg - c.roll_deg, p.end_u_px - c.axis_u_px, p.end_v_px - c.tip_v_px,
      p.gauge_v_px - gauge.y(), (p.gauge_v_px - gauge.y()) * c.mm_per_px * 1e3);
  ASSERT_TRUE(p.pitch_measured);
  EXPECT_GE(p.blade_images, 20);
  EXPECT_NEAR(p.pitch_deg, c.pitch_deg, kPitchTolDeg);
  EXPECT_NEAR(p.roll_deg, c.roll_deg, kRollTolDeg);
  EXPECT_NEAR(p.mm_per_px / c.mm_per_px, 1.0, kScaleTol);
  EXPECT_NEAR(p.end_u_px, c.axis_u_px, kEndAcrossTolPx);
  EXPECT_NEAR(p.end_v_px, c.tip_v_px, kAlongTolPx);  // 1 um, where the end row alone is 1 um off
  EXPECT_NEAR(p.gauge_v_px, gauge.y(), kAlongTolPx);
  const ToolCameraModel tool_camera = p.CameraFor(c, 80.0);
  const geometry::Vec2 tip = c.PixelFromTool({0, pin.length_mm - 80.0});
  EXPECT_NEAR(tool_camera.axis_u_px, tip.x(), kGaugeAcrossTolPx);
  EXPECT_NEAR(tool_camera.tip_v_px, tip.y(), kAlongTolPx);
  // Blades of one length cannot be told apart: refused, as are images not round the turn.
  ToolDescription even = pin;
  even.blades[1].extends_mm = even.blades[0].extends_mm;
  EXPECT_THROW(CalibrateWithPin(frames, positions, 36, c, even), ToolInputError);
  EXPECT_THROW(CalibrateWithPin({frames.begin(), frames.begin() + 4}, {0, 1, 2, 3}, 36, c, pin),
               ToolError);
}

// The lens' distortion is the pin's to measure, not the manifest's: rendered through a lens of
// k1 = 0.0008 (0.08 % at the corner) and calibrated with the manifest saying 0.0002, 36 images
// of the pin over 95 % of the height: the flanks' straightness gives k1, and the scale and
// axis are as with the lens known.
TEST(ToolCalibration, ThePinsFlanksGiveTheLensDistortion) {
  const ToolDescription pin = LoadTool(kTools + "calibration_pin_d3.json");
  ToolCameraModel c;  // the pin's end low in the image: its flanks over 95 % of the height
  c.axis_u_px = 511.3, c.tip_v_px = 740.4, c.drops_per_frame = 0, c.roll_deg = 0.25;
  c.distortion_k1 = 0.0008;
  std::mt19937 rng(32);
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<int> positions;
  for (int k = 0; k < 36; ++k) {
    frames.push_back(RenderToolFrame(pin, c, k * M_PI / 18, 0, rng).pixels);
    positions.push_back(k);
  }
  ToolCameraModel manifest = c;
  manifest.distortion_k1 = 0.0002;
  const PinCalibration p = CalibrateWithPin(frames, positions, 36, manifest, pin);
  // Three images of the pin ending mid-image do not determine it: the manifest's stands.
  std::vector<std::vector<std::uint8_t>> few;
  ToolCameraModel mid = c;
  mid.tip_v_px = 560.4;
  for (int k = 0; k < 3; ++k) few.push_back(RenderToolFrame(pin, mid, k, 0, rng).pixels);
  const PinCalibration q = CalibrateWithPin(few, {0, 1, 2}, 6, manifest, pin);
  EXPECT_FALSE(q.distortion_measured) << "k1 " << q.distortion_k1 << " +- " << q.distortion_sigma;
  EXPECT_EQ(q.distortion_k1, 0.0002);
  const geometry::Vec2 gauge = c.PixelFromTool({0, pin.length_mm});
  std::printf(
      "lens: k1 %.6f +- %.6f (true 0.000800), scale %+.1f ppm, gauge row %+.2f px, roll %+.4f "
      "deg\n",
      p.distortion_k1, p.distortion_sigma, (p.mm_per_px / c.mm_per_px - 1) * 1e6,
      p.gauge_v_px - gauge.y(), p.roll_deg - c.roll_deg);
  EXPECT_TRUE(p.distortion_measured);
  EXPECT_NEAR(p.distortion_k1, 0.0008, kDistortionTol);
  EXPECT_NEAR(p.mm_per_px / c.mm_per_px, 1.0, kScaleTol);
  EXPECT_NEAR(p.end_u_px, c.axis_u_px, kEndAcrossTolPx);
  EXPECT_NEAR(p.gauge_v_px, gauge.y(), kAlongTolPx);
  EXPECT_NEAR(p.roll_deg, c.roll_deg, kRollTolDeg);
}

// A clean tool with coolant drops at the camera's usual rate (1.5 a frame), 100 seeded runs
// at a coarser 14.4 deg step (25 images: the sweep's time): not one finding, every edge within
// the drops' tolerance.
TEST(ToolMeasure, NoFalseFindingsOnACleanToolOver100SeededRuns) {
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  ToolCameraModel c = SmallCamera(1.5);
  c.height_px = 500, c.tip_v_px = 440;  // h up to 1.76 mm
  int findings = 0;
  double worst_um = 0;
  for (unsigned seed = 100; seed < 200; ++seed) {
    const MeasuredRun run = RenderAndMeasure(nominal, nominal, c, seed, 14.4);
    for (const FluteMeasurement& f : run.m.flutes) {
      findings += static_cast<int>(f.plus.findings.size());
      for (const Finding& d : f.plus.findings)
        std::printf("  seed %u: %s at h %.3f mm, %.1f um, %.3f mm long\n", seed,
                    d.buildup ? "build-up" : "wear", d.h_mm, d.max_mm * 1e3, d.length_mm);
      worst_um =
          std::max({worst_um, std::abs(f.radius_mm - 5.0) * 1e3, std::abs(f.tip_h_mm) * 1e3});
    }
  }
  std::printf("100 runs: %d findings, worst edge error %.2f um\n", findings, worst_um);
  EXPECT_EQ(findings, 0);
  EXPECT_LT(worst_um, kDropsTolMm * 1e3);
}

}  // namespace
}  // namespace mlp::toolcam
