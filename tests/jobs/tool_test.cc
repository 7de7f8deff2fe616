// The tool job in-process (issue 53): a strobe plan's frames of an end mill rendered by the
// virtual tool camera (its truth known: tests/toolcam/tool_runs.h), measured and decided on as
// the service's tool job does, without images on disk, a daemon or a socket.

#include "mlp/jobs/tool.h"

#include "../toolcam/tool_runs.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

const std::string kTools = test::SourceDir() + "/samples/tools/";
constexpr double kCleanTolMm = 0.001;  // issue 7: radius and length within 1 um, clean tool
constexpr double kMaxChangeMm = 0.2;   // the machine's limit (PlausibilityLimits' default)

// A 400 x 600 camera with the tool's +y flank (R 5) in the middle of the image.
toolcam::ToolCameraModel SmallCamera() {
  toolcam::ToolCameraModel c;
  c.width_px = 400, c.height_px = 600;
  c.axis_u_px = 200 - 5.0 / c.mm_per_px;
  c.tip_v_px = 520;
  return c;
}

ToolFrames Rendered(const toolcam::ToolDescription& tool, unsigned seed) {
  const toolcam::ToolCameraModel camera = SmallCamera();
  toolcam::test::RenderedSeries s = toolcam::test::RenderSeries(tool, camera, seed);
  ToolFrames f;
  f.pixels = std::move(s.frames);
  f.position = std::move(s.positions);
  f.positions = s.position_count;
  f.camera = camera;
  return f;
}

// The D10 end mill as it runs: the worn one's runout and lengths without its defects.
toolcam::ToolDescription CleanRunout() {
  toolcam::ToolDescription t = toolcam::LoadTool(kTools + "endmill_d10_z4_worn.json");
  for (auto& e : t.edges) e.defects.clear();
  return t;
}

ToolInputs Inputs(const toolcam::ToolDescription& truth, unsigned seed) {
  ToolInputs in;
  in.tool = toolcam::LoadTool(kTools + "endmill_d10_z4_new.json");
  in.tool_number = 12;
  in.images = Rendered(truth, seed);
  return in;
}

// LinuxCNC's table for T12 as the service reads it: length and radius before.
std::array<nc::ToolOffsetChange, 2> Table(double length_mm, double radius_mm) {
  return {nc::ToolOffsetChange{12, nc::ToolRegister::kLengthGeometry, length_mm, length_mm, false},
          nc::ToolOffsetChange{12, nc::ToolRegister::kRadiusGeometry, radius_mm, radius_mm, false}};
}

TEST(ToolJob, ACleanEndMillsRadiusAndLengthGoToTheTableAbsolute) {
  const ToolInputs in = Inputs(CleanRunout(), 11);
  const ToolOutcome o = AssessTool(in);
  ASSERT_TRUE(std::holds_alternative<toolcam::ToolMeasurement>(o.measurement));
  EXPECT_NEAR(o.radius_mm, 5.006, kCleanTolMm);                      // edge 2 cuts the wall
  EXPECT_NEAR(o.length_mm, in.tool.length_mm + 0.004, kCleanTolMm);  // and the floor
  EXPECT_FALSE(o.over_wear_limit);

  const nc::NcResult out = ToolChanges(o, in, 3, true, Table(in.tool.length_mm, 5.0));
  ASSERT_EQ(out.tools.size(), 2u);
  EXPECT_EQ(out.tools[0].after_mm, o.length_mm);
  EXPECT_EQ(out.tools[1].after_mm, o.radius_mm);
  EXPECT_EQ(out.tools[1].before_mm, 5.0);
  EXPECT_FALSE(out.tools[1].incremental);
  ASSERT_EQ(out.named.size(), 3u);
  EXPECT_TRUE(ToolRefusal(o, in, out, kMaxChangeMm, true).empty());
}

TEST(ToolJob, AWrongToolNumberIsRefusedByTheChangeItWouldMake) {
  const ToolInputs in = Inputs(CleanRunout(), 12);
  const ToolOutcome o = AssessTool(in);
  // T12's table row holds a D6 drill: the D10 measured would move its diameter by 4 mm.
  const nc::NcResult out = ToolChanges(o, in, 4, true, Table(in.tool.length_mm, 3.0));
  const auto refusal = ToolRefusal(o, in, out, kMaxChangeMm, true);
  ASSERT_EQ(refusal.size(), 1u);
  EXPECT_NE(refusal[0].find("diameter would change"), std::string::npos) << refusal[0];
  // A control whose values the host cannot read (Fanuc-style): no such check, the write is
  // absolute from 0 and the control's own limits stand.
  const nc::NcResult blind = ToolChanges(o, in, 4, false, Table(0.0, 0.0));
  EXPECT_TRUE(ToolRefusal(o, in, blind, kMaxChangeMm, false).empty());
}

TEST(ToolJob, AWornToolIsRefusedUnlessItsFindingsAreAccepted) {
  ToolInputs in = Inputs(toolcam::LoadTool(kTools + "endmill_d10_z4_worn.json"), 13);
  const ToolOutcome o = AssessTool(in);
  ASSERT_TRUE(o.over_wear_limit);
  EXPECT_GT(o.worst_finding_mm, in.tool.wear_limit_mm);
  const nc::NcResult out = ToolChanges(o, in, 5, true, Table(in.tool.length_mm, 5.0));
  const auto refusal = ToolRefusal(o, in, out, kMaxChangeMm, true);
  ASSERT_EQ(refusal.size(), 1u);
  EXPECT_NE(refusal[0].find("beyond the tool's wear limit"), std::string::npos) << refusal[0];
  in.accept_findings = true;
  EXPECT_TRUE(ToolRefusal(o, in, out, kMaxChangeMm, true).empty());
}

TEST(ToolJob, AStylusWithoutItsTriggerFramesIsRefusedAsInput) {
  ToolInputs in;  // its idle frames do not matter: the trigger's are missing
  in.tool = toolcam::LoadTool(kTools + "endmill_d10_z4_new.json");
  in.tool.stylus = true;
  EXPECT_THROW(AssessTool(in), RequestError);
}

}  // namespace
}  // namespace mlp::jobs
