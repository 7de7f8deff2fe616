// The virtual tool camera against its own truth: the tool description (parsed, refused with
// reasons), the edge geometry (corner, runout, defects), the rendered shadow's edge where the
// geometry puts it (side and tip, sub-pixel), determinism for a seed, drops where the truth
// says, and a strobe plan's sequence with its truth file.

#include "mlp/toolcam/tool_camera.h"

#include <cmath>
#include <filesystem>
#include <fstream>

#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp::toolcam {
namespace {

namespace fs = std::filesystem;
const std::string kTools = mlp::test::SourceDir() + "/samples/tools/";
constexpr double kEdgeTolPx = 0.03;      // the renderer's sub-rows and blur samples
constexpr double kModelExactMm = 1e-12;  // the tool model's own geometry, computed again
// A near-level edge: its cover is found on 32 sub-rows a pixel, to 1/64 px (tool_camera.cc),
// and the linear crossing below is biased by up to 0.02 px by the blur's curvature.
constexpr double kLevelEdgeTolPx = 0.04;

// A camera with nothing but the optics' symmetric blur: edges must sit exactly where the
// geometry says.
ToolCameraModel CleanCamera() {
  ToolCameraModel c;
  c.distortion_k1 = 0, c.noise_sigma = 0, c.drops_per_frame = 0;
  return c;
}

double Px(const ToolFrame& f, const ToolCameraModel& c, int u, int v) {
  return f.pixels[static_cast<size_t>(v * c.width_px + u)];
}

// Where row v crosses half way from shadow to light, left to right [px].
double RowCrossing(const ToolFrame& f, const ToolCameraModel& c, int v) {
  const double mid = (c.bright + c.dark) / 2;
  for (int u = 0; u + 1 < c.width_px; ++u) {
    const double a = Px(f, c, u, v), b = Px(f, c, u + 1, v);
    if (a < mid && b >= mid) return u + (mid - a) / (b - a);
  }
  return std::nan("");
}

// Where column u crosses half way from shadow (above) to light (below) [px].
double ColumnCrossing(const ToolFrame& f, const ToolCameraModel& c, int u) {
  const double mid = (c.bright + c.dark) / 2;
  for (int v = 0; v + 1 < c.height_px; ++v) {
    const double a = Px(f, c, u, v), b = Px(f, c, u, v + 1);
    if (a < mid && b >= mid) return v + (mid - a) / (b - a);
  }
  return std::nan("");
}

TEST(ToolModel, ReadsTheSamplesAndRefusesBadOnes) {
  const ToolDescription worn = LoadTool(kTools + "endmill_d10_z4_worn.json");
  EXPECT_EQ(worn.flutes, 4);
  EXPECT_EQ(worn.edges.size(), 4u);
  EXPECT_NEAR(worn.TipH(1), -0.004, kModelExactMm);  // edge 2 reaches 4 um lower
  const ToolDescription fresh = LoadTool(kTools + "endmill_d10_z4_new.json");
  EXPECT_EQ(fresh.edges.size(), 4u);  // no edges listed: a true-running tool
  const auto why = [](const std::string& text) {
    try {
      ParseTool(text);
    } catch (const ToolInputError& e) {
      return std::string(e.what());
    }
    return std::string("parsed");
  };
  const std::string head = R"({"format": "mlprobe-tool/1", "id": "x", "length_mm": 50, )";
  EXPECT_NE(why(head + R"("diameter_mm": 10, "flutes": 0, "flute_length_mm": 20})").find("flutes"),
            std::string::npos);
  EXPECT_NE(
      why(head + R"("diameter_mm": -1, "flutes": 2, "flute_length_mm": 20})").find("diameter_mm"),
      std::string::npos);
  EXPECT_NE(why(head + R"("diameter_mm": 10, "flutes": 2, "flute_length_mm": 20, "edges": [{}]})")
                .find("one edge per flute"),
            std::string::npos);
  EXPECT_NE(why("{}").find("format"), std::string::npos);
  // A reference height on the end's shape (a D10 ball nose's reaches 5 mm): refused.
  const std::string ball = R"("diameter_mm": 10, "flutes": 2, "flute_length_mm": 20, )"
                           R"("corner_radius_mm": 5, "reference_height_mm": )";
  EXPECT_NE(why(head + ball + "4}").find("reference_height_mm"), std::string::npos);
  EXPECT_EQ(ParseTool(ToJson(ParseTool(head + ball + "5.5}"))).reference_height_mm, 5.5);
}

TEST(ToolModel, EdgeGeometry) {
  const ToolDescription t = LoadTool(kTools + "endmill_d10_z4_worn.json");
  EXPECT_NEAR(t.EdgeRadius(1, 2.0), 5.006, kModelExactMm);           // runout
  EXPECT_NEAR(t.EdgeRadius(0, 0.0), 5.001 - 0.5, kModelExactMm);     // the corner's bottom
  EXPECT_NEAR(t.EdgeRadius(0, 0.5), 5.001, kModelExactMm);           // the corner's top
  EXPECT_NEAR(t.EdgeRadius(2, 1.325), 4.998 - 0.02, kModelExactMm);  // the chip's deepest point
  EXPECT_NEAR(t.EdgeRadius(0, 0.75), 5.001 + 0.015, kModelExactMm);  // the built-up edge's top
  EXPECT_EQ(t.EdgeRadius(2, 0.0005), 0.0);  // below edge 3's tip, 1 um short
  EXPECT_GT(t.EdgeRadius(1, -0.003), 0.0);  // edge 2 reaches lower
}

TEST(ToolCamera, TheShadowsEdgeIsWhereTheGeometryPutsIt) {
  const ToolDescription t = LoadTool(kTools + "endmill_d10_z4_worn.json");
  const ToolCameraModel c = CleanCamera();
  // Edge 2 (k = 1, radius 5.006) pointing at +y at the height of row 200.
  const int row = 200;
  const double h = c.ToolFromPixel({c.axis_u_px, row}).y();
  const double turn = M_PI / 2 - t.EdgeAngle(1, h, 0.0);
  std::mt19937 rng(1);
  const ToolFrame f = RenderToolFrame(t, c, turn, 0.0, rng);
  const double expected_u = t.EdgeRadius(1, h) / c.mm_per_px + c.axis_u_px;
  EXPECT_NEAR(RowCrossing(f, c, row), expected_u, kEdgeTolPx);
  // The tip under that edge, 1 mm in from the side (on the flat end): edge 2's tip, 4 um low.
  const int column = static_cast<int>(std::lround((5.0 - 1.0) / c.mm_per_px + c.axis_u_px));
  EXPECT_NEAR(ColumnCrossing(f, c, column), c.tip_v_px - t.TipH(1) / c.mm_per_px, kEdgeTolPx);
}

// A camera turned about x (roll) and y (pitch): the pin's blades (turned 45 deg, one 0.64 mm
// nearer, one farther) end where the geometry puts them, each lower by its depth times
// tan(pitch) (at its middle column, where its round end's far side shows: depth + r); the
// flank crosses each row where the rolled mapping says.
TEST(ToolCamera, AMountTurnedAboutXAndYShowsWhereTheGeometrySays) {
  ToolDescription pin = LoadTool(kTools + "calibration_pin_d3_blades.json");
  ToolCameraModel c = CleanCamera();
  c.axis_u_px = 505.7, c.tip_v_px = 300.2, c.roll_deg = 0.4, c.pitch_deg = 0.5;
  const double turn = M_PI / 4, tan_pitch = std::tan(c.pitch_deg * M_PI / 180);
  std::mt19937 rng(3);
  const ToolFrame f = RenderToolFrame(pin, c, turn, 0.0, rng);
  for (const PinBlade& b : pin.blades) {
    const double y = b.offset_mm * std::sin(turn), depth = b.offset_mm * std::cos(turn);
    const double h_end = -b.extends_mm - (depth + b.width_mm / 2) * tan_pitch;
    // The end at the blade's middle: down its column from the row of the blade's middle.
    const geometry::Vec2 end = c.PixelFromTool({y, h_end});
    const int column = static_cast<int>(std::lround(end.x()));
    const double seen_h =
        c.ToolFromPixel({static_cast<double>(column), ColumnCrossing(f, c, column)}).y();
    const double expected_h =
        -b.extends_mm -
        (depth +
         b.width_mm / 2 *
             std::sqrt(1 -
                       std::pow((c.ToolFromPixel({static_cast<double>(column), end.y()}).x() - y) /
                                    (b.width_mm / 2),
                                2))) *
            tan_pitch;
    EXPECT_NEAR(seen_h, expected_h, kLevelEdgeTolPx * c.mm_per_px) << "blade at " << b.offset_mm;
  }
  const int row = 100;  // the right flank (y = +1.5) on a row above the end
  const double h_row = c.ToolFromPixel({c.axis_u_px, static_cast<double>(row)}).y();
  const geometry::Vec2 a = c.PixelFromTool({1.5, h_row - 0.1}),
                       b = c.PixelFromTool({1.5, h_row + 0.1});
  const double expected_u = a.x() + (b.x() - a.x()) * (row - a.y()) / (b.y() - a.y());
  EXPECT_NEAR(RowCrossing(f, c, row), expected_u, kEdgeTolPx);
}

TEST(ToolCamera, DeterministicForASeedWithDropsWhereTheTruthSays) {
  const ToolDescription t = LoadTool(kTools + "endmill_d10_z4_new.json");
  ToolCameraModel c;
  c.drops_per_frame = 6;
  std::mt19937 a(7), b(7), other(8);
  const ToolFrame fa = RenderToolFrame(t, c, 0.3, 0.001, a);
  const ToolFrame fb = RenderToolFrame(t, c, 0.3, 0.001, b);
  EXPECT_EQ(fa.pixels, fb.pixels);
  EXPECT_NE(fa.pixels, RenderToolFrame(t, c, 0.3, 0.001, other).pixels);
  ASSERT_FALSE(fa.drops.empty());
  for (const Drop& d : fa.drops) {  // each drop's centre is dark
    const double u = d.y_mm / c.mm_per_px + c.axis_u_px, v = c.tip_v_px - d.h_mm / c.mm_per_px;
    if (u < 2 || v < 2 || u > c.width_px - 3 || v > c.height_px - 3) continue;
    EXPECT_LT(Px(fa, c, static_cast<int>(std::lround(u)), static_cast<int>(std::lround(v))),
              (c.bright + c.dark) / 2)
        << "drop at (" << d.y_mm << ", " << d.h_mm << ") r " << d.radius_mm;
  }
}

TEST(ToolCamera, ASequenceFollowsItsStrobePlanAndWritesItsTruth) {
  const ToolDescription t = LoadTool(kTools + "endmill_d10_z4_worn.json");
  StrobeRequest r;
  r.rpm = 5000, r.frame_rate_hz = 50, r.resolution_deg = 45;
  const StrobePlan plan = PlanStrobe(r);
  const fs::path dir = fs::temp_directory_path() / "mlp_tool_camera_test";
  fs::remove_all(dir);
  ASSERT_EQ(RenderToolSequence(t, ToolCameraModel(), plan, 0.4, 3, dir.string()), 8);
  std::ifstream in(dir / "truth.json");
  const auto truth = nlohmann::json::parse(in);
  EXPECT_EQ(truth.at("format"), "mlprobe-tool-frames/1");
  EXPECT_EQ(truth.at("frames").size(), 8u);
  EXPECT_NEAR(truth.at("edges")[1].at("radius_mm").get<double>(), 5.006, kModelExactMm);
  EXPECT_EQ(fs::file_size(dir / "frame_0007.pgm"), 16u + 1024u * 768u);  // "P5\n1024 768\n255\n"
}

}  // namespace
}  // namespace mlp::toolcam
