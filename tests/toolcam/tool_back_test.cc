// A tooth's back in the tool model (issue 51): the silhouette a land, its relief, a drill's
// margin and body clearance add beside the cutting edge, against a brute-force sweep of the
// back's outline; the hands of helix and cut and the spindle's direction as the files state
// them; the files' checks.

#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/tool_images.h"
#include "mlp/toolcam/tool_model.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

constexpr double kSilhouetteTolMm = 1e-7;  // the sweep's own step leaves ~1e-9 mm
constexpr double kDegPerRad = 180.0 / M_PI;

ToolDescription EndMill() {
  return ParseTool(R"({"format": "mlprobe-tool/1", "id": "EM8", "diameter_mm": 8, "length_mm": 60,
    "flutes": 3, "helix_deg": 35, "flute_length_mm": 20, "core_ratio": 0.6,
    "land_width_mm": 0.25, "land_relief_deg": 9, "clearance_relief_deg": 22})");
}

ToolDescription Drill() {
  return ParseTool(R"({"format": "mlprobe-tool/1", "id": "DR6", "diameter_mm": 6, "length_mm": 70,
    "flutes": 2, "helix_deg": 30, "point_angle_deg": 118, "flute_length_mm": 40,
    "core_ratio": 0.2, "land_width_mm": 0.4, "body_clearance_mm": 0.12, "heel_deg": 85})");
}

// The shadow's +y extent at height h by sweeping every edge's back in steps of 2e-6 rad:
// radius R - drop(psi) behind the edge, on the side its motion leaves (clockwise-counted
// model angle: a right-hand cut's back at smaller angles), never beyond the edge's radius at
// that height; the blade and the web as the model has them.
double SweptHi(const ToolDescription& t, double h, double turn) {
  const double r = t.Radius(), sigma = t.left_hand_cut ? 1.0 : -1.0;
  const double heel = (t.heel_deg > 0 ? t.heel_deg : 180.0 / t.flutes) / kDegPerRad;
  const double land = t.land_width_mm / r, a1 = std::tan(t.land_relief_deg / kDegPerRad);
  const double a2 = std::tan(t.clearance_relief_deg / kDegPerRad);
  double hi = 0;
  for (int k = 0; k < t.flutes; ++k) {
    const double edge_r = t.EdgeRadius(k, h), at = t.EdgeAngle(k, h, turn);
    if (edge_r <= 0) continue;
    hi = std::max(hi, std::min(t.core_ratio * r, edge_r));
    // the land's and the heel's ends exactly (a maximum sits there often)
    const int n_land = static_cast<int>(land / 2e-6) + 1,
              n_rest = static_cast<int>((heel - land) / 2e-6) + 1;
    for (int i = 0; i <= n_land + n_rest; ++i) {
      const double psi =
          i <= n_land ? land * i / n_land : land + (heel - land) * (i - n_land) / n_rest;
      const double s = psi * r;
      double drop = psi <= land ? s * a1 : land * r * a1 + (s - land * r) * a2;
      if (i > n_land && t.body_clearance_mm > 0) drop = t.body_clearance_mm;
      hi = std::max(hi, std::min(r - drop, edge_r) * std::sin(at + sigma * psi));
    }
  }
  return hi;
}

double ModelHi(const ToolDescription& t, double h, double turn) {
  double lo = 0, hi = 0;
  t.ShadowSpan(h, turn, &lo, &hi);
  return hi;
}

TEST(ToolBack, ALandAndItsReliefsShadeAsTheirOutlineDoes) {
  const ToolDescription t = EndMill();
  for (const double h : {0.5, 2.0, 7.0})
    for (double turn = 0; turn < 2 * M_PI / 3; turn += 0.11)
      EXPECT_NEAR(ModelHi(t, h, turn), SweptHi(t, h, turn), kSilhouetteTolMm) << h << " " << turn;
}

TEST(ToolBack, ADrillsMarginAndBodyClearanceShadeAsTheirOutlineDoes) {
  const ToolDescription t = Drill();
  for (const double h : {0.6, 1.5, 5.0})  // on the point, at its shoulder, on the body
    for (double turn = 0; turn < M_PI; turn += 0.13)
      EXPECT_NEAR(ModelHi(t, h, turn), SweptHi(t, h, turn), kSilhouetteTolMm) << h << " " << turn;
}

TEST(ToolBack, ALeftHandCutsBackTrailsTheOtherWay) {
  ToolDescription right = Drill(), left = Drill();
  left.left_hand_cut = true;
  for (double turn = 0; turn < M_PI; turn += 0.17)
    EXPECT_NEAR(ModelHi(left, 5.0, turn), SweptHi(left, 5.0, turn), kSilhouetteTolMm);
  // The edge facing +y at h 5 on the body: 0.1 rad later (clockwise) a right-hand cut's
  // margin (0.4 mm: 0.133 rad behind, counterclockwise) still faces +y at the full radius,
  // a left-hand cut's has turned away; 0.1 rad earlier the other way round.
  const double facing = M_PI / 2 - right.EdgeAngle(0, 5.0, 0.0);
  const double turned_away = 3.0 * std::cos(0.1);
  EXPECT_NEAR(ModelHi(right, 5.0, facing + 0.1), 3.0, kSilhouetteTolMm);
  EXPECT_NEAR(ModelHi(left, 5.0, facing + 0.1), turned_away, kSilhouetteTolMm);
  EXPECT_NEAR(ModelHi(left, 5.0, facing - 0.1), 3.0, kSilhouetteTolMm);
  EXPECT_NEAR(ModelHi(right, 5.0, facing - 0.1), turned_away, kSilhouetteTolMm);
}

TEST(ToolBack, HelixHandAndSpindleDirectionAsTheFilesSayThem) {
  // The model counts the turn clockwise seen from the spindle (M3's way): a right-hand helix
  // winds counterclockwise as it rises, so its edge's model angle falls with height.
  const ToolDescription right = EndMill();
  EXPECT_LT(right.EdgeAngle(0, 1.0, 0.0), right.EdgeAngle(0, 0.0, 0.0));
  ToolDescription left = right;
  left.left_hand_helix = true;
  EXPECT_GT(left.EdgeAngle(0, 1.0, 0.0), left.EdgeAngle(0, 0.0, 0.0));
  EXPECT_TRUE(ParseTool(ToJson(left)).left_hand_helix);
  // Under M4 the strobe's position p is the clockwise turn's 40 - p.
  const std::string manifest = R"({"format": "mlprobe-tool-images/1",
    "camera": {"width_px": 640, "height_px": 480, "mm_per_px": 0.004},
    "strobe": {"rpm": 3000, "positions": 40, "pulse_width_us": 1},
    "spindle": {"direction": "M4"},
    "images": [{"file": "a.png", "position": 0}, {"file": "b.png", "position": 7}]})";
  const ToolImages m4 = ParseToolImages(manifest, "test");
  EXPECT_TRUE(m4.m4);
  EXPECT_EQ(m4.position[0], 0);
  EXPECT_EQ(m4.position[1], 33);
  std::string bad = manifest;
  bad.replace(bad.find("M4"), 2, "CW");
  EXPECT_THROW(ParseToolImages(bad, "test"), ToolInputError);
}

// The winding the images show against the hand the tool file states: a right-hand D10 (helix
// 30 deg) said to be left-hand, or its series said to turn M4, is refused as bad input; as
// stated it is measured. (A wrong hand left radius and length alone; it sent the end's corner
// examination to the wrong image.)
TEST(ToolBack, AHelixStatedTheWrongWayIsRefused) {
  ToolDescription tool =
      LoadTool(mlp::test::SourceDir() + "/samples/tools/endmill_d10_z4_new.json");
  const test::RenderedSeries s = test::RenderSeries(tool, test::FlankCamera(5.0), 11);
  const auto measure = [&](const ToolDescription& nominal, const std::vector<int>& positions) {
    return MeasureTool(s.frames, positions, s.position_count, nominal, test::FlankCamera(5.0));
  };
  EXPECT_NO_THROW(measure(tool, s.positions));
  ToolDescription said_left = tool;
  said_left.left_hand_helix = true;
  EXPECT_THROW(measure(said_left, s.positions), ToolInputError);
  std::vector<int> as_m4 = s.positions;  // what ParseToolImages makes of "direction": "M4"
  for (int& p : as_m4) p = (s.position_count - p) % s.position_count;
  EXPECT_THROW(measure(tool, as_m4), ToolInputError);
}

TEST(ToolBack, TheFilesChecksNameTheField) {
  const std::string head = R"({"format": "mlprobe-tool/1", "id": "X", "diameter_mm": 8,
    "length_mm": 60, "flutes": 3, "flute_length_mm": 20, )";
  EXPECT_THROW(ParseTool(head + R"("land_relief_deg": 8})"), ToolInputError);  // no land
  EXPECT_THROW(ParseTool(head + R"("land_width_mm": 0.2, "land_relief_deg": 35})"), ToolInputError);
  EXPECT_THROW(ParseTool(head + R"("land_width_mm": 0.2, "body_clearance_mm": 1.5})"),
               ToolInputError);
  EXPECT_THROW(ParseTool(head + R"("land_width_mm": 5, "heel_deg": 30})"), ToolInputError);
  EXPECT_THROW(ParseTool(head + R"("helix_hand": "up"})"), ToolInputError);
  const ToolDescription back = ParseTool(ToJson(Drill()));
  EXPECT_DOUBLE_EQ(back.body_clearance_mm, 0.12);
  EXPECT_DOUBLE_EQ(back.heel_deg, 85);
}

}  // namespace
}  // namespace mlp::toolcam
