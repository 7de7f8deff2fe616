// What a real camera and strobe tell the measurement (issue 51): a lens with its principal
// point off the image's centre and tangential terms; each image's angle as measured (an
// encoder's angle, or the time since the index pulse) where the strobe fired late or early,
// and each image's own pulse; the manifest's checks on them.

#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/tool_images.h"
#include "mlp/toolcam/tool_model.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

using test::EdgeFacing;
using test::WholeToolCamera;

constexpr double kRoundTripPx = 1e-6;  // Undistort(Distort(p)): its fixed point
constexpr double kEdgeTolMm = 0.001;   // issue 7's figure: each edge within 1 um
constexpr double kAngleTolDeg = 0.1;   // a flute's angle with the images' angles measured
constexpr double kLateDeg = 0.8;       // the strobe's lateness, RMS (a free-running camera)

ToolDescription SmallEndMill() {
  ToolDescription t = ParseTool(R"({"format": "mlprobe-tool/1", "id": "EM2", "diameter_mm": 2,
    "length_mm": 40, "flutes": 3, "helix_deg": 30, "flute_length_mm": 6, "core_ratio": 0.6,
    "land_width_mm": 0.06, "land_relief_deg": 8, "clearance_relief_deg": 20})");
  t.edges[1].radial_offset_mm = 0.002, t.edges[2].axial_offset_mm = 0.001;
  return t;
}

ToolCameraModel DecentredLens() {
  ToolCameraModel c = WholeToolCamera();
  c.principal_u_px = 300.0, c.principal_v_px = 300.0;
  c.distortion_k1 = 0.0006, c.distortion_p1 = 0.002, c.distortion_p2 = -0.0015;
  return c;
}

TEST(ToolLens, DistortAndUndistortAreInverse) {
  const ToolCameraModel c = DecentredLens();
  for (const geometry::Vec2& p : {geometry::Vec2(0, 0), geometry::Vec2(639, 0),
                                  geometry::Vec2(320, 280), geometry::Vec2(10, 550)})
    EXPECT_LT((c.Undistort(c.Distort(p)) - p).norm(), kRoundTripPx) << p.transpose();
  // What the terms move at the corner (the test below means something): over 1 px.
  EXPECT_GT((c.Undistort({0, 0}) - geometry::Vec2(0, 0)).norm(), 1.0);
}

// Each edge's radius within 1 um through the decentred lens given whole; without its
// principal point and tangential terms the same images read worse.
TEST(ToolLens, ADecentredLensIsUndoneWithItsPrincipalPointAndTangentialTerms) {
  const ToolDescription tool = SmallEndMill(), nominal = ParseTool(R"({"format": "mlprobe-tool/1",
    "id": "EM2", "diameter_mm": 2, "length_mm": 40, "flutes": 3, "helix_deg": 30,
    "flute_length_mm": 6, "core_ratio": 0.6, "land_width_mm": 0.06, "land_relief_deg": 8,
    "clearance_relief_deg": 20})");
  const ToolCameraModel lens = DecentredLens();
  ToolCameraModel radial_only = lens;
  radial_only.principal_u_px.reset(), radial_only.principal_v_px.reset();
  radial_only.distortion_p1 = radial_only.distortion_p2 = 0;
  const test::RenderedSeries s = test::RenderSeries(tool, lens, 61);
  const MeasureOptions opt = ForTool(nominal);
  const auto worst_with = [&](const ToolCameraModel& c) {
    const ToolMeasurement m = MeasureTool(s.frames, s.positions, s.position_count, nominal, c, opt);
    double worst = 0;
    for (const FluteMeasurement& f : m.flutes) {
      const auto k = static_cast<size_t>(
          EdgeFacing(tool, s.turn[static_cast<size_t>(f.plus.frame)], opt.h_ref_mm));
      worst =
          std::max(worst, std::abs(f.radius_mm - tool.Radius() - tool.edges[k].radial_offset_mm));
    }
    return worst;
  };
  const double worst_whole = worst_with(lens), worst_radial = worst_with(radial_only);
  std::printf("  worst radius error: the lens whole %.2f um, radial only %.2f um\n",
              worst_whole * 1e3, worst_radial * 1e3);
  EXPECT_LT(worst_whole, kEdgeTolMm);
  EXPECT_GT(worst_radial, worst_whole);
}

// A strobe that fires late or early by 0.8 deg RMS: with each image's angle as measured the
// flutes' angles and radii hold; given only the plan's positions, the angles are off.
TEST(ToolStrobe, MeasuredAnglesStandForALateStrobe) {
  const ToolDescription tool = SmallEndMill();
  ToolDescription nominal = tool;
  for (CuttingEdge& e : nominal.edges) e = CuttingEdge{};
  const ToolCameraModel c = WholeToolCamera();
  StrobeRequest r;
  r.rpm = 5000, r.frame_rate_hz = 50, r.resolution_deg = 7.2;
  const StrobePlan plan = PlanStrobe(r);
  std::mt19937 rng(62);
  std::normal_distribution<double> late(0, kLateDeg);
  const double start = 1.1;
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<double> measured_deg, turn;
  for (const int pos : plan.position) {
    const double deg = 360.0 * pos / plan.positions + late(rng);
    measured_deg.push_back(deg), turn.push_back(start + deg / 180 * M_PI);
    frames.push_back(RenderToolFrame(tool, c, turn.back(), 0.0, rng).pixels);
  }
  const MeasureOptions opt = ForTool(nominal);
  const ToolMeasurement with = MeasureTool(
      ToolSeries{frames, plan.position, plan.positions, c, &measured_deg}, nominal, opt);
  const ToolMeasurement plan_only =
      MeasureTool(frames, plan.position, plan.positions, nominal, c, opt);
  double worst_with = 0, worst_plan = 0;
  for (const ToolMeasurement* m : {&with, &plan_only}) {
    ASSERT_EQ(m->flutes.size(), 3u);
    for (const FluteMeasurement& f : m->flutes) {
      const int k = EdgeFacing(tool, turn[static_cast<size_t>(f.plus.frame)], opt.h_ref_mm);
      // where edge k faces +y at the reference height, counted as the images are
      const double true_deg =
          (M_PI / 2 - tool.EdgeAngle(k, opt.h_ref_mm, 0.0) - start) * 180 / M_PI;
      const double err = std::abs(base::WrapDeg(f.angle_deg - true_deg));
      double& worst = m == &with ? worst_with : worst_plan;
      worst = std::max(worst, err);
      if (m == &with) {
        EXPECT_NEAR(f.radius_mm,
                    tool.Radius() + tool.edges[static_cast<size_t>(k)].radial_offset_mm,
                    kEdgeTolMm);
      }
    }
  }
  std::printf("  worst flute angle error: measured angles %.3f deg, the plan's %.3f deg\n",
              worst_with, worst_plan);
  EXPECT_LT(worst_with, kAngleTolDeg);
  EXPECT_GT(worst_plan, worst_with);
}

std::string Manifest(const std::string& images, const std::string& direction = "M3") {
  return R"({"format": "mlprobe-tool-images/1", "camera": {"width_px": 64, "height_px": 48,
    "mm_per_px": 0.004, "principal_u_px": 30, "principal_v_px": 20, "distortion_p1": 1e-4,
    "distortion_p2": -1e-4}, "strobe": {"rpm": 6000, "positions": 40, "pulse_width_us": 2},
    "spindle": {"direction": ")" +
         direction + R"("}, "images": [)" + images + "]}";
}

TEST(ToolImagesFile, MeasuredAnglesTimesAndPulsesAreRead) {
  const ToolImages im =
      ParseToolImages(Manifest(R"({"file": "a.pgm", "angle_deg": 9.3, "pulse_width_us": 4},
                 {"file": "b.pgm", "position": 2, "angle_deg": 18.5})"),
                      "t");
  ASSERT_EQ(im.angle_deg.size(), 2u);
  EXPECT_DOUBLE_EQ(im.angle_deg[0], 9.3);
  EXPECT_EQ(im.position[0], 1);  // the nearest of 40
  EXPECT_EQ(im.position[1], 2);
  const double rad_per_us = 6000.0 / 60 * 2 * M_PI * 1e-6;
  ASSERT_EQ(im.image_blur_rad.size(), 2u);
  EXPECT_DOUBLE_EQ(im.image_blur_rad[0], 4 * rad_per_us);
  EXPECT_DOUBLE_EQ(im.image_blur_rad[1], 2 * rad_per_us);  // the strobe's
  EXPECT_DOUBLE_EQ(*im.camera.principal_u_px, 30.0);
  EXPECT_DOUBLE_EQ(im.camera.distortion_p2, -1e-4);
  // time since the index pulse: 6000 rpm is 0.036 deg a microsecond; M4 counts it back
  const ToolImages t = ParseToolImages(Manifest(R"({"file": "a.pgm", "time_us": 250})", "M4"), "t");
  ASSERT_EQ(t.angle_deg.size(), 1u);
  EXPECT_NEAR(t.angle_deg[0], 360.0 - 9.0, 1e-9);
  EXPECT_EQ(t.position[0], 39);
  EXPECT_TRUE(
      ParseToolImages(Manifest(R"({"file": "a.pgm", "position": 3})"), "t").angle_deg.empty());
}

TEST(ToolImagesFile, InconsistentAnglesAreRefused) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"file": "a.pgm", "angle_deg": 9}, {"file": "b.pgm", "position": 2})", "every image"},
      {R"({"file": "a.pgm", "position": 5, "angle_deg": 9})", "more than a position"},
      {R"({"file": "a.pgm", "angle_deg": 9, "time_us": 250})", "not both"},
      {R"({"file": "a.pgm"})", "no position nor angle"},
      {R"({"file": "a.pgm", "angle_deg": 9, "pulse_width_us": -1})", "pulse_width_us"},
  };
  for (const auto& [images, says] : bad) {
    try {
      ParseToolImages(Manifest(images), "t");
      ADD_FAILURE() << images;
    } catch (const ToolInputError& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mlp::toolcam
