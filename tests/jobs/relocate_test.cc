// The relocate job in-process (issue 53): an EDM electrode's texture rendered by the virtual
// reflected-light camera (its truth known) before and after re-clamping, found again and its
// offsets decided on as the service's relocate job does, against a LinuxCNC tool table read
// through nc's rules.

#include "mlp/jobs/relocate.h"

#include "mlp/nc/tool_table_update.h"

#include <cmath>
#include <random>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

const std::string kTools = test::SourceDir() + "/samples/tools/";
constexpr double kRad = M_PI / 180;
constexpr double kShiftTolMm = 0.0005;  // as toolcam's own test: 64 patches at 5 um a pixel
constexpr double kTurnTolDeg = 0.002;

// 512 x 512 px at 5 um, square to the face, 0.3 mm above the electrode's end (as toolcam's).
toolcam::TextureCamera Camera() {
  toolcam::TextureCamera c;
  c.geometry.width_px = 512, c.geometry.height_px = 512;
  c.geometry.mm_per_px = 0.005;
  c.geometry.axis_u_px = 255.5, c.geometry.tip_v_px = 511.5 + 0.3 / 0.005;
  c.geometry.distortion_k1 = 0, c.geometry.drops_per_frame = 0;
  return c;
}

TextureFrames Frames(const toolcam::ToolDescription& e,
                     const toolcam::ClampPose& pose,
                     unsigned seed) {
  std::mt19937 rng(seed);
  TextureFrames f;
  f.turn_deg = {0, 90, 180, 270};
  for (double t : f.turn_deg)
    f.pixels.push_back(toolcam::RenderTextureFrame(e, pose, t * kRad, Camera(), rng));
  f.camera = Camera().geometry;
  return f;
}

toolcam::ClampPose Pose(const geometry::Vec3& rotation_deg) {
  toolcam::ClampPose p;
  p.rotation_rad = rotation_deg * kRad;
  p.translation_mm = geometry::Vec3(0.030, -0.020, 0.015);
  return p;
}

RelocateInputs Inputs(const geometry::Vec3& rotation_deg, unsigned seed) {
  RelocateInputs in;
  in.electrode = toolcam::LoadTool(kTools + "electrode_10x6.json");
  in.tool_number = 30;
  in.reference = Frames(in.electrode, {}, seed);
  in.now = Frames(in.electrode, Pose(rotation_deg), seed + 1);
  return in;
}

// T30's row in LinuxCNC's table, each asked change resolved against it (nc's rules).
std::vector<nc::ToolOffsetChange> ResolvedOnTable(const std::vector<OffsetChangeAsked>& asked) {
  const nc::ToolTable table = nc::ToolTable::Parse("T30 P30 Z101.2 D10 ;electrode\n", "tool.tbl");
  std::vector<nc::ToolOffsetChange> out;
  std::string note;
  for (const OffsetChangeAsked& a : asked)
    out.push_back(nc::ResolveOnTable(table, "tool.tbl", 30, a.reg, a.change, &note));
  return out;
}

const RelocateMachine kFourAxis{"XYZC", true, 0.2, 1.0};

TEST(RelocateJob, AnElectrodeTurnedAndShiftedGetsItsFourOffsetsBack) {
  const RelocateInputs in = Inputs({0, 0, 0.4}, 31);
  const toolcam::Relocation r = AssessRelocate(in);
  EXPECT_NEAR(r.rotation_deg[2], 0.4, kTurnTolDeg);
  EXPECT_LT(r.tilt_deg, kTurnTolDeg);
  const auto asked = RelocateChangesAsked(r, kFourAxis);
  ASSERT_EQ(asked.size(), 4u);
  const nc::NcResult out = RelocateChanges(in, r, 6, ResolvedOnTable(asked));
  ASSERT_EQ(out.tools.size(), 4u);
  // Length, X, Y, C: the table's value less the electrode's motion.
  EXPECT_NEAR(out.tools[0].after_mm, 101.2 - 0.015, kShiftTolMm);
  EXPECT_NEAR(out.tools[1].after_mm, -0.030, kShiftTolMm);
  EXPECT_NEAR(out.tools[2].after_mm, 0.020, kShiftTolMm);
  EXPECT_NEAR(out.tools[3].after_mm, -0.4, kTurnTolDeg);
  EXPECT_TRUE(RelocateRefusal(in, r, out, kFourAxis).empty());
}

TEST(RelocateJob, WithoutACAxisTheTurnIsNotWrittenAndBeyondTheLimitRefused) {
  const RelocateInputs in = Inputs({0, 0, 0.4}, 41);
  const toolcam::Relocation r = AssessRelocate(in);
  const RelocateMachine three_axis{"XYZ", true, 0.2, 1.0};
  const auto asked = RelocateChangesAsked(r, three_axis);
  ASSERT_EQ(asked.size(), 3u);
  for (const OffsetChangeAsked& a : asked) EXPECT_NE(a.reg, nc::ToolRegister::kOffsetC);
  const nc::NcResult out = RelocateChanges(in, r, 7, ResolvedOnTable(asked));
  const auto refusal = RelocateRefusal(in, r, out, three_axis);
  ASSERT_EQ(refusal.size(), 1u);
  EXPECT_NE(refusal[0].find("no C axis"), std::string::npos) << refusal[0];
}

TEST(RelocateJob, ATiltNoOffsetCorrectsIsRefused) {
  const RelocateInputs in = Inputs({0.02, -0.03, 0.4}, 51);  // tilted 0.036 deg
  const toolcam::Relocation r = AssessRelocate(in);
  EXPECT_NEAR(r.tilt_deg, std::hypot(0.02, 0.03), kTurnTolDeg);
  const nc::NcResult out =
      RelocateChanges(in, r, 8, ResolvedOnTable(RelocateChangesAsked(r, kFourAxis)));
  const auto refusal = RelocateRefusal(in, r, out, kFourAxis);
  ASSERT_EQ(refusal.size(), 1u);
  EXPECT_NE(refusal[0].find("tilted"), std::string::npos) << refusal[0];
}

TEST(RelocateJob, ACutterIsNotAnElectrode) {
  RelocateInputs in;
  in.electrode = toolcam::LoadTool(kTools + "endmill_d10_z4_new.json");
  EXPECT_THROW(AssessRelocate(in), RequestError);
}

}  // namespace
}  // namespace mlp::jobs
