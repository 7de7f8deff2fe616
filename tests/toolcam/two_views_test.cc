// Two illuminator / detector pairs (seed 000 example 7) against the virtual tool camera's
// truth: the spindle axis has drifted off where both cameras' calibrations put it, partly
// along camera A's view, which A alone cannot see; a second camera, its view turned from A's
// about the spindle (its mount's angle 2 deg off), triangulates it. Also each edge as a point
// in space, the pair's angle measured from the tool, the stylus' ball in space, and the pairs
// that cannot work refused.

#include "mlp/toolcam/two_views.h"

#include "mlp/toolcam/touch_probe.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "test_data.h"
#include "tool_runs.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

const std::string kTools = mlp::test::SourceDir() + "/samples/tools/";
constexpr double kAcrossTolMm = 0.0005;  // the axis across a view (tool_kinds' kAxisTolMm)
// Along A's view: the two views' errors over sin(view) (1.04 at 74 deg), and a turn's worth
// of the view angle's error (about 0.2 deg over 6 um).
constexpr double kDepthTolMm = 0.001;
constexpr double kEdgeTolMm = 0.001;      // each edge's radius (issue 7's figure)
constexpr double kViewTolDeg = 0.3;       // the pair's angle from four flutes, images 7.2 deg apart
constexpr double kEdgeAngleTolDeg = 0.5;  // where an edge stood at position 0
constexpr double kBallTolMm = 0.001;      // the stylus ball's centre in space
constexpr double kRad = M_PI / 180;

// The drift: the spindle axis off where the calibrations put it, in A's frame [mm].
struct Drift {
  double x_mm = 0, y_mm = 0;
  // Across a view turned `view_deg` from A's.
  double Across(double view_deg) const {
    return -std::sin(view_deg * kRad) * x_mm + std::cos(view_deg * kRad) * y_mm;
  }
};

// What a camera whose view is turned `view_deg` from A's sees with the spindle drifted: its
// calibration's camera with the axis moved across its image.
ToolCameraModel Drifted(const ToolCameraModel& c, const Drift& d, double view_deg) {
  ToolCameraModel seen = c;
  seen.axis_u_px += d.Across(view_deg) / c.mm_per_px;
  return seen;
}

// The same pulses' frames in a camera turned `view_deg`: it sees the tool that much of its
// turn later (test::RenderSeries' plan, start and order).
std::vector<std::vector<std::uint8_t>> FramesInView(const ToolDescription& tool,
                                                    const ToolCameraModel& c,
                                                    const test::RenderedSeries& a,
                                                    double view_deg,
                                                    unsigned seed) {
  std::mt19937 rng(seed);
  const double blur = 0.1 * 2 * M_PI / a.position_count;  // pulses a tenth of a step
  std::vector<std::vector<std::uint8_t>> frames;
  for (double turn : a.turn)
    frames.push_back(RenderToolFrame(tool, c, turn - view_deg * kRad, blur, rng).pixels);
  return frames;
}

TEST(TwoViews, ASecondCameraSeesTheAxisAlongTheFirstsView) {
  const ToolDescription tool = LoadTool(kTools + "endmill_d2_z4_runout.json");
  ToolDescription nominal = tool;
  for (auto& e : nominal.edges) e = CuttingEdge{};
  const double true_view_deg = 74.0;
  const SecondView mount{72.0, 10.0};  // the mount's drawing says 72
  const Drift drift{0.006, -0.004};
  const ToolCameraModel calibrated = test::WholeToolCamera();
  const test::RenderedSeries a = test::RenderSeries(tool, Drifted(calibrated, drift, 0), 71);
  const auto b_frames =
      FramesInView(tool, Drifted(calibrated, drift, true_view_deg), a, true_view_deg, 72);
  MeasureOptions options;
  options.h_ref_mm = 1.0;
  options.blur_rad = 0.1 * 2 * M_PI / a.position_count;
  const ToolIn3d t = MeasureToolFromTwoViews({a.frames, a.positions, a.position_count, calibrated},
                                             {b_frames, a.positions, a.position_count, calibrated},
                                             nominal, mount, options);
  std::printf(
      "two views: angle %.3f deg (true %.1f, mount %.1f, rms %.3f); axis x %+.2f um (true %+.2f), "
      "y %+.2f um (true %+.2f); A alone %+.2f um across; depth gain %.3f; tips %+.2f um apart\n",
      t.view_deg, true_view_deg, mount.view_deg, t.view_rms_deg, t.axis_offset_mm.x() * 1e3,
      drift.x_mm * 1e3, t.axis_offset_mm.y() * 1e3, drift.y_mm * 1e3, t.a.axis_offset_mm * 1e3,
      t.depth_gain, t.tip_disagreement_mm * 1e3);
  EXPECT_NEAR(t.view_deg, true_view_deg, kViewTolDeg);
  EXPECT_NEAR(t.axis_offset_mm.x(), drift.x_mm, kDepthTolMm);
  EXPECT_NEAR(t.axis_offset_mm.y(), drift.y_mm, kAcrossTolMm);
  EXPECT_NEAR(t.axis_offset_mm.z(), 0.0, 1e-12);
  // A alone sees the drift across its image and nothing of the 6 um along its view.
  EXPECT_NEAR(t.a.axis_offset_mm, drift.y_mm, kAcrossTolMm);
  EXPECT_NEAR(t.b.axis_offset_mm, drift.Across(true_view_deg), kAcrossTolMm);
  EXPECT_NEAR(t.tip_disagreement_mm, 0.0, kEdgeTolMm);
  double longest = 0;  // the longest edge's tip (edge 2, 2 um long)
  for (int k = 0; k < tool.flutes; ++k) longest = std::min(longest, tool.TipH(k));
  EXPECT_NEAR(t.tip_h_mm, longest, kEdgeTolMm);
  ASSERT_EQ(t.edge_mm.size(), 4u);
  for (size_t k = 0; k < t.edge_mm.size(); ++k) {
    // Which edge this flute is (A's principal image), and that B's pair is the same edge.
    const FluteMeasurement& fa = t.a.flutes[k];
    const FluteMeasurement& fb = t.b.flutes[static_cast<size_t>(t.b_flute[k])];
    const int e = test::EdgeFacing(tool, a.turn[static_cast<size_t>(fa.plus.frame)], 1.0);
    EXPECT_EQ(test::EdgeFacing(
                  tool, a.turn[static_cast<size_t>(fb.plus.frame)] - true_view_deg * kRad, 1.0),
              e)
        << "B's flute is another edge";
    const double r = tool.Radius() + tool.edges[static_cast<size_t>(e)].radial_offset_mm;
    const double at_0 = tool.EdgeAngle(e, 1.0, a.start_turn);
    const geometry::Vec3 truth(drift.x_mm + r * std::cos(at_0), drift.y_mm + r * std::sin(at_0),
                               1.0);
    const geometry::Vec3& seen = t.edge_mm[k];
    const double angle_error_deg = test::WrapDeg(
        (std::atan2(seen.y() - t.axis_offset_mm.y(), seen.x() - t.axis_offset_mm.x()) - at_0) /
        kRad);
    std::printf(
        "  edge %d: radius %.4f mm (%+.2f um; A - B %+.2f um), at position 0 %+.3f deg "
        "off, %.2f um from the truth in space\n",
        e + 1, t.radius_mm[k], (t.radius_mm[k] - r) * 1e3, t.radius_disagreement_mm[k] * 1e3,
        angle_error_deg, (seen - truth).norm() * 1e3);
    EXPECT_NEAR(t.radius_mm[k], r, kEdgeTolMm) << "edge " << e + 1;
    EXPECT_NEAR(angle_error_deg, 0.0, kEdgeAngleTolDeg) << "edge " << e + 1;
    EXPECT_NEAR(seen.z(), 1.0, 1e-12);
  }
}

// The stylus idle (seed 000 Fig. 6) seen by both: its ball's centre in space. A alone cannot
// tell that the ball stands 5 um along its view.
TEST(TwoViews, TheStylusBallInSpace) {
  const ToolDescription stylus = LoadTool(kTools + "stylus_d2.json");
  const double view_deg = 120.0;
  const Drift drift{-0.005, 0.003};
  const ToolCameraModel calibrated = test::WholeToolCamera();
  std::mt19937 rng(73);
  std::vector<std::vector<std::uint8_t>> in_a, in_b;
  for (int k = 0; k < 4; ++k) {
    in_a.push_back(RenderToolFrame(stylus, Drifted(calibrated, drift, 0), k * 0.5, 0, rng).pixels);
    in_b.push_back(
        RenderToolFrame(stylus, Drifted(calibrated, drift, view_deg), k * 0.5, 0, rng).pixels);
  }
  const StylusSeen sa = MeasureStylus(in_a, calibrated, stylus);
  const StylusSeen sb = MeasureStylus(in_b, calibrated, stylus);
  const geometry::Vec3 c =
      Triangulate(sa.centre_y_mm, sa.centre_h_mm, sb.centre_y_mm, sb.centre_h_mm, view_deg);
  const double true_h = stylus.TipH(0) + stylus.Radius();
  std::printf(
      "stylus ball in space: (%+.2f, %+.2f) um across the axis (true (%+.2f, %+.2f)), "
      "centre %.5f mm up (true %.5f)\n",
      c.x() * 1e3, c.y() * 1e3, drift.x_mm * 1e3, drift.y_mm * 1e3, c.z(), true_h);
  EXPECT_NEAR(c.x(), drift.x_mm, kBallTolMm);
  EXPECT_NEAR(c.y(), drift.y_mm, kBallTolMm);
  EXPECT_NEAR(c.z(), true_h, kBallTolMm);
}

TEST(TwoViews, TriangulatesAPointAndRefusesNearParallelViews) {
  // A point at (3, -2) mm seen by views 90 and 40 deg apart, and 3 mm up.
  for (double v : {90.0, 40.0, -130.0}) {
    const double y_b = -std::sin(v * kRad) * 3 + std::cos(v * kRad) * -2;
    const geometry::Vec3 p = Triangulate(-2, 3, y_b, 3, v);
    EXPECT_NEAR(p.x(), 3, 1e-12) << v;
    EXPECT_NEAR(p.y(), -2, 1e-12) << v;
    EXPECT_NEAR(p.z(), 3, 1e-12) << v;
  }
  for (double v : {0.0, 10.0, 170.0, -175.0, 360.0, std::nan("")})
    EXPECT_THROW(Triangulate(0, 0, 0, 0, v), ToolInputError) << v;
}

TEST(TwoViews, PairsThatCannotWorkAreRefused) {
  const ToolDescription tool = LoadTool(kTools + "endmill_d2_z4_runout.json");
  const ToolCameraModel c = test::WholeToolCamera();
  const test::RenderedSeries a = test::RenderSeries(tool, c, 74);
  const auto b_frames = FramesInView(tool, c, a, 90, 75);
  MeasureOptions options;
  options.h_ref_mm = 1.0;
  const ToolSeries sa{a.frames, a.positions, a.position_count, c};
  const ToolSeries sb{b_frames, a.positions, a.position_count, c};
  // Near parallel, and a tolerance as wide as half the pitch (flutes could pair either way).
  EXPECT_THROW(MeasureToolFromTwoViews(sa, sb, tool, {5.0, 10.0}, options), ToolInputError);
  EXPECT_THROW(MeasureToolFromTwoViews(sa, sb, tool, {90.0, 45.0}, options), ToolInputError);
  // Not the same pulses.
  std::vector<int> other = a.positions;
  std::swap(other[0], other[1]);
  EXPECT_THROW(MeasureToolFromTwoViews(sa, {b_frames, other, a.position_count, c}, tool,
                                       {90.0, 10.0}, options),
               ToolInputError);
  // The mount 40 deg off what the tool shows: no flute of B where A's says.
  try {
    MeasureToolFromTwoViews(sa, sb, tool, {130.0, 10.0}, options);
    ADD_FAILURE() << "a mount 40 deg off was taken";
  } catch (const ToolError& e) {
    EXPECT_NE(std::string(e.what()).find("second view's angle"), std::string::npos) << e.what();
  }
  // The pair right: it measures.
  const ToolIn3d t = MeasureToolFromTwoViews(sa, sb, tool, {90.0, 10.0}, options);
  EXPECT_NEAR(t.view_deg, 90.0, kViewTolDeg);
}

}  // namespace
}  // namespace mlp::toolcam
