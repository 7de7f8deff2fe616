// A sinking EDM electrode (seed 000 example 5) measured from the virtual tool camera's frames
// against its truth: a 10 x 6 mm section turned slowly, 360 images a degree apart, its +y
// flank in the field. Each corner's wear on its own, radially and from its length; the images'
// turn from the truncated +y shadow function shifted against the model's; the corners named
// by the chuck's angle, by a stored reference's wear, or said to be named only up to a half
// turn; the wear limit's verdict for the controller. All in the virtual camera's world (our
// renderer, the measurement's own tool model): a check of the code, not an accuracy figure.

#include "mlp/toolcam/measure.h"

#include <cmath>
#include <cstdio>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

using test::EdgeFacing;
using test::MeasuredRun;
using test::RenderAndMeasure;
using test::RunSetup;

const std::string kTools = mlp::test::SourceDir() + "/samples/tools/";
constexpr double kWearTolMm = 0.001;         // issue 7's figure for an edge: 1 um
constexpr double kAngleTolDeg = 0.25;        // a corner's place in the turn (images 1 deg apart)
constexpr double kChuckErrorDeg = 4.0;       // how far off the chuck's angle may be told
constexpr double kResolutionDeg = 1.0;       // the seed's 360 images (70 rpm, 60 images/s)
constexpr double kQuickResolutionDeg = 3.0;  // 120 images: the naming and the wear alike

// Corner k's wear in the truth against the nominal: radially in, and up from the end.
double TrueRadialWear(const ToolDescription& t, int k) {
  return -t.edges[static_cast<size_t>(k)].radial_offset_mm;
}
double TrueAxialWear(const ToolDescription& t, int k) {
  return -t.edges[static_cast<size_t>(k)].axial_offset_mm;
}

void Print(const char* what, const ToolMeasurement& m) {
  std::printf("%s: worst wear %.2f um%s\n", what, m.worst_wear_mm * 1e3,
              m.half_turn_ambiguous ? " (corners named up to a half turn)" : "");
  for (const FluteMeasurement& f : m.flutes)
    std::printf("  corner %d at %7.2f deg: in %6.2f um, up %6.2f um\n", f.edge + 1, f.angle_deg,
                f.radial_wear_mm * 1e3, f.axial_wear_mm * 1e3);
}

TEST(Electrode, EachCornersWearNamedByTheChucksAngle) {
  const ToolDescription worn = LoadTool(kTools + "electrode_10x6_worn.json");
  const ToolDescription nominal = LoadTool(kTools + "electrode_10x6.json");
  ASSERT_TRUE(nominal.electrode);
  const ToolCameraModel c = test::FlankCamera(nominal.Radius());
  RunSetup setup;
  setup.resolution_deg = kResolutionDeg;
  // The chuck's angle, a few degrees off: it picks the half turn, the images fix the rest.
  setup.options.start_turn_deg = test::StartTurnDeg(61) + kChuckErrorDeg;
  const MeasuredRun run = RenderAndMeasure(worn, nominal, c, 61, setup);
  Print("chuck-named", run.m);
  ASSERT_EQ(run.m.flutes.size(), 4u);
  EXPECT_FALSE(run.m.half_turn_ambiguous);
  for (const FluteMeasurement& f : run.m.flutes) {
    const int k = EdgeFacing(worn, run.turn[static_cast<size_t>(f.plus.frame)], 1.5);
    EXPECT_EQ(f.edge, k) << "the chuck names the corner";
    EXPECT_NEAR(test::WrapDeg(f.angle_deg - run.PeakDeg(worn, k, 1.5)), 0.0, kAngleTolDeg);
    EXPECT_NEAR(f.radial_wear_mm, TrueRadialWear(worn, k), kWearTolMm) << "corner " << k + 1;
    EXPECT_NEAR(f.axial_wear_mm, TrueAxialWear(worn, k), kWearTolMm) << "corner " << k + 1;
  }
  EXPECT_NEAR(run.m.worst_wear_mm, 0.030, kWearTolMm);
  EXPECT_TRUE(run.m.OverWearLimit(worn)) << "corner 4: 30 um up against a 25 um limit";
  EXPECT_DOUBLE_EQ(run.m.worst_finding_mm, 0.0) << "uniform wear is no local finding";
}

TEST(Electrode, WithoutTheChuckTheCornersAreNamedUpToAHalfTurn) {
  const ToolDescription worn = LoadTool(kTools + "electrode_10x6_worn.json");
  const ToolDescription nominal = LoadTool(kTools + "electrode_10x6.json");
  RunSetup setup;
  setup.resolution_deg = kQuickResolutionDeg;
  const MeasuredRun run =
      RenderAndMeasure(worn, nominal, test::FlankCamera(nominal.Radius()), 62, setup);
  Print("unnamed", run.m);
  EXPECT_TRUE(run.m.half_turn_ambiguous);
  for (const FluteMeasurement& f : run.m.flutes) {
    const int k = EdgeFacing(worn, run.turn[static_cast<size_t>(f.plus.frame)], 1.5);
    EXPECT_TRUE(f.edge == k || f.edge == (k + 2) % 4) << "corner " << k + 1;
    // The wear is the corner's in view, whatever it was called.
    EXPECT_NEAR(f.radial_wear_mm, TrueRadialWear(worn, k), kWearTolMm);
    EXPECT_NEAR(f.axial_wear_mm, TrueAxialWear(worn, k), kWearTolMm);
  }
  EXPECT_NEAR(run.m.worst_wear_mm, 0.030, kWearTolMm);
}

// Stored after a first measurement (the chuck named the corners), the reference names them
// the next time from their wear alone, turned half way round in the chuck, and the wear is
// what happened since.
TEST(Electrode, AStoredReferenceNamesTheCornersAndMeasuresTheWearSince) {
  const ToolDescription nominal = LoadTool(kTools + "electrode_10x6.json");
  const ToolDescription worn = LoadTool(kTools + "electrode_10x6_worn.json");
  ToolDescription early = worn;  // the first measurement: a third of the wear
  for (CuttingEdge& e : early.edges) e.radial_offset_mm /= 3, e.axial_offset_mm /= 3;
  const ToolCameraModel c = test::FlankCamera(nominal.Radius());
  RunSetup first;
  first.resolution_deg = kQuickResolutionDeg;
  first.options.start_turn_deg = test::StartTurnDeg(63);
  const MeasuredRun run1 = RenderAndMeasure(early, nominal, c, 63, first);
  const ToolDescription reference = ReferenceFrom(nominal, run1.m);
  RunSetup second;
  second.resolution_deg = kQuickResolutionDeg;
  const MeasuredRun run2 = RenderAndMeasure(worn, reference, c, 64, second);
  Print("against the reference", run2.m);
  EXPECT_FALSE(run2.m.half_turn_ambiguous);
  for (const FluteMeasurement& f : run2.m.flutes) {
    const int k = EdgeFacing(worn, run2.turn[static_cast<size_t>(f.plus.frame)], 1.5);
    EXPECT_EQ(f.edge, k) << "the wear pattern names the corner";
    EXPECT_NEAR(f.radial_wear_mm, TrueRadialWear(worn, k) * 2 / 3, kWearTolMm);
    EXPECT_NEAR(f.axial_wear_mm, TrueAxialWear(worn, k) * 2 / 3, kWearTolMm);
  }
  EXPECT_FALSE(run2.m.OverWearLimit(reference)) << "20 um since, under the 25 um limit";
}

TEST(Electrode, TheFileSaysTheSectionAndIsRefusedWhenItDoesNotHoldTogether) {
  const ToolDescription e = LoadTool(kTools + "electrode_10x6.json");
  EXPECT_NEAR(e.diameter_mm, std::hypot(10.0, 6.0), 1e-12);
  EXPECT_EQ(e.flutes, 4);
  ASSERT_EQ(e.flute_angles_deg.size(), 4u);
  EXPECT_NEAR(e.flute_angles_deg[1], 180 - 2 * std::atan2(6.0, 10.0) * 180 / M_PI, 1e-9);
  EXPECT_NEAR(e.core_ratio * e.Radius(), 3.0, 1e-12);  // the inscribed circle
  const ToolDescription back = ParseTool(ToJson(e));
  EXPECT_TRUE(back.electrode);
  EXPECT_EQ(back.section_mm[0], 10.0);
  EXPECT_EQ(back.section_mm[1], 6.0);
  EXPECT_EQ(back.flute_angles_deg, e.flute_angles_deg);
  const std::string head =
      R"({"format": "mlprobe-tool/1", "id": "E", "kind": "electrode", "length_mm": 60,
          "flute_length_mm": 20, )";
  for (const char* bad :
       {R"("section_mm": [10]})", R"("section_mm": [10, 0]})", R"("section_mm": [10, 0.2]})",
        R"("section_mm": "10x6"})", R"("section_mm": [10, 6], "helix_deg": 30})",
        R"("section_mm": [10, 6], "diameter_mm": 12})", R"("section_mm": [10, 6], "flutes": 2})",
        R"("section_mm": [10, 6], "point_angle_deg": 118})", "}"})
    EXPECT_THROW(ParseTool(head + bad), ToolInputError) << bad;
}

}  // namespace
}  // namespace mlp::toolcam
