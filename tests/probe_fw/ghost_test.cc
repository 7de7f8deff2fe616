// Indirect light told from the stripe by the sweep: on one row, two traces of stripe centres that
// cover the same pixels at columns far apart cannot both be direct light; the weaker loses,
// where neither is weaker both do; traces on different pixels (a bore's two walls) both stay.

#include "mlp/probe_fw/ghost.h"

#include "test_data.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

// A trace on row `y`: frames first..last, centre x0 + px_per_frame * (frame - first), lit at
// column 2 * frame + column_offset.
void AddTrace(std::vector<SweepObservation>* obs,
              int y,
              int first,
              int last,
              double x0,
              double px_per_frame,
              double column_offset,
              double amplitude) {
  for (int f = first; f <= last; ++f) {
    SweepObservation o;
    o.stripe.x_px = x0 + px_per_frame * (f - first);
    o.stripe.y_px = y;
    o.stripe.amplitude_dn = amplitude;
    o.column = 2.0 * f + column_offset;
    o.frame = f;
    obs->push_back(o);
  }
}

std::size_t Indirect(const std::vector<SweepObservation>& obs, double amplitude) {
  std::size_t n = 0;
  for (const auto& o : obs) n += o.indirect && o.stripe.amplitude_dn == amplitude;
  return n;
}

// Kept out of the cloud: indirect, or doubted by the ordering test (still a reference for the
// tests after it).
std::size_t Out(const std::vector<SweepObservation>& obs, double amplitude) {
  std::size_t n = 0;
  for (const auto& o : obs) n += (o.indirect || o.doubted) && o.stripe.amplitude_dn == amplitude;
  return n;
}

TEST(RejectIndirectLight, AWeakerTraceOverTheStripesPixelsIsRejectedWhole) {
  std::vector<SweepObservation> obs;
  for (int y = 0; y < 3; ++y) {
    AddTrace(&obs, y, 0, 99, 100.0, 3.2, 0.0, 120.0);  // the stripe: 3.2 px a frame
    // The ghost: 40 px ahead, drifting 1.2 px a frame more, at half the light. Its last frames
    // are beyond the stripe's pixels: rejected with the rest of its trace.
    AddTrace(&obs, y, 0, 99, 140.0, 4.4, 0.0, 60.0);
  }
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 300u);
  EXPECT_EQ(Indirect(obs, 60.0), 300u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
}

TEST(RejectIndirectLight, SurfacesOnDifferentPixelsAndOneSurfaceSeenTwiceAllStay) {
  std::vector<SweepObservation> obs;
  // A bore's near and far wall on one row: two traces on separate pixels, different brightness.
  AddTrace(&obs, 5, 0, 49, 100.0, 2.0, 0.0, 150.0);
  AddTrace(&obs, 5, 0, 49, 400.0, 1.5, 0.0, 40.0);
  // A steep face: the stripe barely moves, consecutive frames see the same pixels at nearby
  // columns (within the sheet's reach): one surface, no conflict.
  AddTrace(&obs, 6, 0, 49, 300.0, 0.3, 0.0, 90.0);
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 0u);
}

TEST(RejectIndirectLight, NeitherClearlyWeakerBothGoAndABlipLosesToALongTrace) {
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 0, 0, 59, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 0, 0, 59, 130.0, 4.0, 0.0, 80.0);  // 0.8 of the light: cannot tell
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 120u);

  obs.clear();
  AddTrace(&obs, 1, 0, 59, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 1, 40, 41, 200.5, 3.0, 0.0, 110.0);  // a bright 2-frame blip far off the sweep
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 2u);
  EXPECT_EQ(Indirect(obs, 110.0), 2u);
}

TEST(RejectIndirectLight, RowsAreIndependentAndNothingIsAnEmptySweep) {
  std::vector<SweepObservation> none;
  EXPECT_EQ(RejectIndirectLight(&none, {}), 0u);
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 0, 0, 29, 100.0, 3.0, 0.0, 100.0);
  AddTrace(&obs, 1, 0, 29, 130.0, 4.0, 0.0, 50.0);  // another row: no conflict
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 0u);
}

// A plane mirror beside the face: its ghost comes from the projector's mirror image and moves
// against the stripe's way through the sweep. Brighter than the stripe (a mirror of Fresnel
// reflectance ~0.9 beside a dark face), it still loses once the direct way is known; without
// that the brighter trace would win.
TEST(RejectIndirectLight, ABrighterMirrorGhostMovingTheWrongWayLoses) {
  std::vector<SweepObservation> obs;
  // The ghost (frames 0-19, -3 px a frame, 2.5x the light) crosses x 180..123 at the columns of
  // its first frames; the stripe (frames 20-39, +3 px a frame) crosses 160..217 later: the same
  // pixels at columns far apart.
  AddTrace(&obs, 0, 20, 39, 160.0, 3.0, 0.0, 60.0);
  AddTrace(&obs, 0, 0, 19, 180.0, -3.0, 0.0, 150.0);
  GhostOptions o;
  o.row_motion_sign = 1.0;
  std::vector<SweepObservation> with_way = obs;
  EXPECT_EQ(RejectIndirectLight(&with_way, o), 20u);
  EXPECT_EQ(Indirect(with_way, 150.0), 20u);
  EXPECT_EQ(RejectIndirectLight(&obs, {}), 20u);
  EXPECT_EQ(Indirect(obs, 60.0), 20u);  // by light alone the stripe would have gone
  // A ghost on its own, off every pixel of the stripe, moving the wrong way: still indirect.
  std::vector<SweepObservation> alone;
  AddTrace(&alone, 1, 0, 19, 500.0, -2.0, 0.0, 90.0);
  EXPECT_EQ(RejectIndirectLight(&alone, o), 20u);
}

// A one-frame ghost just past the end of the stripe's trace (the AOI's edge ended the trace a
// pixel short of it) conflicts with the trace's next step and loses to the trace's direction.
TEST(RejectIndirectLight, AOneFrameGhostJustPastTheTraceEndLoses) {
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 0, 100, 140, 100.0, 4.0, 0.0, 80.0);  // ends at x = 260, column 280
  AddTrace(&obs, 0, 10, 10, 261.5, 0.0, 0.0, 90.0);    // column 20, a pixel and a half further
  GhostOptions o;
  o.row_motion_sign = 1.0;
  EXPECT_EQ(RejectIndirectLight(&obs, o), 1u);
  EXPECT_EQ(Indirect(obs, 90.0), 1u);
}

// The reference probe's projector sits along +x: direct light moves along the rows as the column
// grows, not along the columns. Turned by 90 deg about the optical axis, the other way round.
TEST(DirectMotion, FollowsTheBaseline) {
  ProbeModel m = LoadProbeModel(mlp::test::SourceDir() + "/samples/probes/reference_probe.json");
  double row = 0.0, column = 0.0;
  DirectMotion(m, &row, &column);
  EXPECT_NE(row, 0.0);
  EXPECT_EQ(column, 0.0);
  // On a face at 120 mm, the sheets of columns 500 and 501 on the line y = 0: the stripe's image
  // moves along x the way DirectMotion says.
  const auto image_x = [&](double projector_column) {
    Vec3 n;
    double d = 0.0;
    m.projector.PlaneOf(projector_column, &n, &d);
    return m.camera.Project(Vec3((d - n.z() * 120.0) / n.x(), 0.0, 120.0)).x();
  };
  EXPECT_GT((image_x(501.0) - image_x(500.0)) * row, 0.0);
  const Eigen::Matrix3d quarter = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  m.projector.camera_from_projector.linear() = quarter * m.projector.camera_from_projector.linear();
  m.projector.camera_from_projector.translation() =
      quarter * m.projector.camera_from_projector.translation();
  double row_turned = 0.0, column_turned = 0.0;
  DirectMotion(m, &row_turned, &column_turned);
  EXPECT_EQ(row_turned, 0.0);
  EXPECT_NE(column_turned, 0.0);
}

// The outside renderers' probes: the projector beside the camera with its middle column
// pointing straight ahead, so the central sheet never meets the optical axis. DirectMotion
// gave no direction there (both signs 0: every direction rule off); it now takes the nearest
// sheet that meets the axis in front.
TEST(DirectMotion, AProjectorWhoseMiddleSheetRunsBesideTheOpticalAxisStillHasADirection) {
  ProbeModel m = LoadProbeModel(mlp::test::SourceDir() + "/samples/probes/reference_probe.json");
  m.projector.camera_from_projector = Pose3::Identity();
  m.projector.camera_from_projector.translation() = Vec3(60.0, 0.0, 0.0);
  m.projector.c_px = 0.5 * m.projector.columns;
  m.projector.mirror_cubic_cols = 0.0;
  double row = 0.0, column = 0.0;
  DirectMotion(m, &row, &column);
  EXPECT_NE(row, 0.0);
  EXPECT_EQ(column, 0.0);
}

// A coarse sweep (110 px between frames) of a plane on one row, and a reflection lit in the last
// frame standing between frames 7 and 8: no other candidate on its epipolar line or its pixel,
// but its column is out of order with the direct light on both sides. It goes; frames 8 and 9,
// the two it could replace in a sequence one shorter (the line's order alone cannot say which of
// them is direct: ALineThatOrdersAlmostAsWellAnotherWayKeepsNeither), leave the cloud too but
// stay references for the later tests. Standing between frames 6 and 7 (two shorter) it goes
// alone.
TEST(RejectOutOfOrder, AReflectionBetweenACoarseSweepsFramesIsOutOfOrder) {
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 200, 0, 9, 100.0, 110.0, 0.0, 120.0);  // columns 0, 2, .. 18
  AddTrace(&obs, 200, 10, 10, 880.0, 0.0, 0.0, 60.0);   // column 20 at 880 px
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 3u);
  EXPECT_EQ(Indirect(obs, 60.0), 1u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u) << "frames 8 and 9 stay references";
  EXPECT_TRUE(obs[8].doubted && obs[9].doubted);
  for (auto& o : obs) o.indirect = o.doubted = false;
  obs.back().stripe.x_px = 770.0;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 1u);
  EXPECT_EQ(Indirect(obs, 60.0), 1u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
  // A fine sweep whose centres step back by up to the tolerance, and a direction unknown on the
  // column axis: nothing marked.
  std::vector<SweepObservation> fine;
  AddTrace(&fine, 3, 0, 40, 500.0, 0.3, 0.0, 100.0);
  for (std::size_t i = 0; i < fine.size(); i += 3) fine[i].stripe.x_px -= 0.8;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &fine), 0u);
  for (auto& o : fine) o.stripe.axis = ScanAxis::kColumn, std::swap(o.stripe.x_px, o.stripe.y_px);
  for (std::size_t i = 0; i < fine.size(); i += 2) fine[i].stripe.y_px += 50.0;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &fine), 0u);
}

// Corpus 7474 scene 47 in small: the direct stripe's last centre on the line (frame 8) and, a
// frame later, a reflection just behind it (the direct stripe has left the image). Either could
// end the longest ordered sequence: neither is kept (the longest sequence's tie went to the later
// one, the reflection, 8 mm off in that scene). The direct centres before them stay.
TEST(RejectOutOfOrder, TwoThatCouldTakeTheSamePlaceAreBothDropped) {
  constexpr double kDirect = 120.0, kReflection = 60.0;
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 1200, 0, 8, 100.0, 100.0, 0.0, kDirect);  // 100 .. 900 px
  AddTrace(&obs, 1200, 9, 9, 867.0, 0.0, 0.0, kReflection);
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 2u);
  EXPECT_EQ(Indirect(obs, kReflection), 1u);
  EXPECT_EQ(Indirect(obs, kDirect), 1u);
  EXPECT_TRUE(obs[8].indirect);  // the frame-8 centre, the one the reflection could replace
}

// Corpus 5050 scene 162 in small: the stripe's last two frames on the line (6, 7 at 700 and 800
// px) and a reflection lagging behind it through frames 8-10 (620, 650, 680 px). Each is in order
// after frames 0-5; the reflection's three make the longer sequence, and were kept (the stripe's
// two went). A sequence only one shorter orders the line the other way: neither way is kept
// (the stripe's two are doubted: out of the cloud, still references), frames 0-5 are.
TEST(RejectOutOfOrder, ALineThatOrdersAlmostAsWellAnotherWayKeepsNeither) {
  constexpr double kDirect = 120.0, kReflection = 60.0;
  std::vector<SweepObservation> obs;
  AddTrace(&obs, 300, 0, 7, 100.0, 100.0, 0.0, kDirect);  // 100 .. 800 px
  AddTrace(&obs, 300, 8, 10, 620.0, 30.0, 0.0, kReflection);
  // The reflection's three lie on the longest sequence: doubted (references still); the
  // stripe's two on the one a member shorter: indirect, as before this rule.
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 5u);
  EXPECT_EQ(Out(obs, kReflection), 3u);
  EXPECT_EQ(Out(obs, kDirect), 2u);
  EXPECT_EQ(Indirect(obs, kReflection), 0u);
  for (int f = 0; f <= 5; ++f) {
    const SweepObservation& o = obs[static_cast<std::size_t>(f)];
    EXPECT_FALSE(o.indirect || o.doubted) << f;
  }
  // Two frames of the reflection: the two ways tie (8 members each) and, as before this rule,
  // the members that could take the same place all go.
  obs.pop_back();
  for (auto& o : obs) o.indirect = o.doubted = false;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 4u);
  EXPECT_EQ(Indirect(obs, kReflection), 2u);
  // One frame of it at 620 px: frames 0-5 and it make a sequence still one shorter than the
  // stripe's, so the stripe's frames 6 and 7 go with it (corpus 5050 scene 179 had the direct
  // light the one frame and a reflection the two). Lagging further, at 520 px (frames 0-4 and
  // it, two shorter), it goes alone.
  obs.pop_back();
  for (auto& o : obs) o.indirect = o.doubted = false;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 3u);
  EXPECT_EQ(Out(obs, kDirect), 2u);
  EXPECT_EQ(Indirect(obs, kDirect), 0u) << "doubted, still references";
  for (auto& o : obs) o.indirect = o.doubted = false;
  obs.back().stripe.x_px = 520.0;
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 1u);
  EXPECT_EQ(Indirect(obs, kDirect), 0u);
}

// Corpus 7777 scene 45 in small: a plane's coarse sweep on row 300 takes sheets 0-2 at 14, 221
// and 428 px; the stripe drops out for sheets 3-5 while a mirror reflection stays, lit at 812 px
// in sheet 4, where the rate puts the direct light at 842: in order, and off the rate by 30 px,
// more than 5 % of the 414 px step + 3 px. It goes; the direct light stays. The same end at 840
// (a plane's rate changing by a few per cent) stays, as do ends after no gap, lines of under
// three members and the axis without a direction.
TEST(RejectOffRate, AnEndAfterAGapOffTheLinesRateGoes) {
  std::vector<SweepObservation> obs;
  const double direct[] = {14.0, 221.0, 428.0};
  for (int f = 0; f < 3; ++f) AddTrace(&obs, 300, f, f, direct[f], 0.0, 0.0, 120.0);
  AddTrace(&obs, 300, 4, 4, 812.0, 0.0, 0.0, 60.0);
  AddTrace(&obs, 301, 0, 5, 14.0, 207.0, 0.0, 100.0);  // another line sees sheets 0-5
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &obs), 1u);
  EXPECT_EQ(Indirect(obs, 60.0), 1u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
  // The same at the other end of the line (the sweep taken the other way).
  for (auto& o : obs) o.indirect = false, o.column = -o.column;
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &obs), 1u);
  EXPECT_EQ(Indirect(obs, 60.0), 1u);

  for (auto& o : obs) o.indirect = false, o.column = -o.column;
  obs[3].stripe.x_px = 840.0;  // 2 px off the rate
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &obs), 0u);
  obs[3].stripe.x_px = 812.0, obs[3].column = 6.0, obs[3].frame = 3;  // no gap: sheet 3
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &obs), 0u);
  std::vector<SweepObservation> two(obs.begin() + 1, obs.begin() + 2);
  two.push_back(obs[3]);
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &two), 0u);
  obs[3].column = 8.0, obs[3].frame = 4;
  for (auto& o : obs) o.stripe.axis = ScanAxis::kColumn;
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &obs), 0u);

  // A sphere towards its limb: the rate grows sheet by sheet (100, 140, 180 px a sheet), and the
  // end after a gap lies where a rate still growing puts it (corpus 5050 scene 84 lost 28 % of
  // its points before the bend was allowed for): kept. The same end on a line whose rate held
  // (the reflection above) still goes.
  std::vector<SweepObservation> limb;
  const double along[] = {100.0, 200.0, 340.0, 520.0};
  for (int f = 0; f < 4; ++f) AddTrace(&limb, 50, f, f, along[f], 0.0, 0.0, 100.0);
  AddTrace(&limb, 50, 6, 6, 520.0 + 6 * 90.0 + 60.0, 0.0, 0.0, 100.0);  // sheet 6
  AddTrace(&limb, 51, 0, 6, 0.0, 100.0, 0.0, 90.0);
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &limb), 0u);
  for (int f = 0; f < 4; ++f) limb[static_cast<std::size_t>(f)].stripe.x_px = 100.0 + 180.0 * f;
  limb[4].stripe.x_px = 640.0 + 2 * 180.0 + 60.0;
  EXPECT_EQ(RejectOffRate(+1.0, 0.0, RateOptions{}, &limb), 1u);
}

// A coarse sweep of a cylinder on row 200 (frames 5-9, about 100 px between them) and a mirror
// reflection walking back through frames 0-3 (corpus 7171, scene 41: 620, 525, 444, 384 px),
// whose last frame falls into order with the direct light: the whole run goes, the direct
// light stays. A fine sweep's noise (back-steps of up to 0.8 px) strings no run together, and a
// single back-step (an occluding edge) is no run.
TEST(RejectBackwardRuns, AReflectionWalkingBackThroughACoarseSweepGoesWhole) {
  std::vector<SweepObservation> obs;
  const double reflection[] = {620.0, 525.0, 444.0, 384.0};
  for (int f = 0; f < 4; ++f) AddTrace(&obs, 200, f, f, reflection[f], 0.0, 0.0, 60.0);
  const double direct[] = {562.0, 674.0, 767.0, 840.0, 900.0};
  for (int f = 5; f < 10; ++f) AddTrace(&obs, 200, f, f, direct[f - 5], 0.0, 0.0, 120.0);
  EXPECT_EQ(RejectBackwardRuns(+1.0, 0.0, 2.0, 2, 2, &obs), 4u);
  EXPECT_EQ(Indirect(obs, 60.0), 4u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
  // Then the ordering test has nothing left to misjudge.
  EXPECT_EQ(RejectOutOfOrder(+1.0, 0.0, 1.0, &obs), 0u);
  // Runs are judged in the sweep's column order, whichever way the frames swept (the outside
  // renderer's frames sweep down the columns): the same sweep taken in reverse.
  for (auto& o : obs) o.indirect = false, o.frame = 9 - o.frame;
  EXPECT_EQ(RejectBackwardRuns(+1.0, 0.0, 2.0, 2, 2, &obs), 4u);
  EXPECT_EQ(Indirect(obs, 60.0), 4u);

  std::vector<SweepObservation> fine;
  AddTrace(&fine, 3, 0, 40, 500.0, 0.3, 0.0, 100.0);
  for (std::size_t i = 0; i < fine.size(); i += 2) fine[i].stripe.x_px -= 0.8;
  EXPECT_EQ(RejectBackwardRuns(+1.0, 0.0, 2.0, 2, 2, &fine), 0u);
  std::vector<SweepObservation> edge;  // a face, then a pin in front of it, then the face on
  AddTrace(&edge, 9, 0, 3, 300.0, 100.0, 0.0, 100.0);
  edge[2].stripe.x_px = 250.0;
  EXPECT_EQ(RejectBackwardRuns(+1.0, 0.0, 2.0, 2, 2, &edge), 0u);
  // The axis without a direction is left alone.
  for (auto& o : obs) o.indirect = false, o.stripe.axis = ScanAxis::kColumn;
  EXPECT_EQ(RejectBackwardRuns(+1.0, 0.0, 2.0, 2, 2, &obs), 0u);
}

// One frame's reflection down rows 30-60, found indirect on all but its two ends, and a direct
// stripe of the same frame beside it with a few of its own marked (a conflict's pixels): the
// reflection goes whole, the stripe keeps the rest.
TEST(SpreadAlongStripes, AStripeMostlyFoundIndirectIsIndirectWhole) {
  std::vector<SweepObservation> obs;
  const auto add = [&](int y, double x, double amplitude, bool indirect) {
    SweepObservation o;
    o.stripe.x_px = x, o.stripe.y_px = y, o.stripe.amplitude_dn = amplitude;
    o.frame = 3, o.column = 6.0, o.indirect = indirect;
    obs.push_back(o);
  };
  for (int y = 30; y <= 60; ++y) add(y, 384.0 + 0.1 * (y - 30), 60.0, y > 31 && y < 59);
  for (int y = 30; y <= 60; ++y) add(y, 700.0 - 0.2 * (y - 30), 120.0, y % 10 == 0);
  EXPECT_EQ(SpreadAlongStripes(3.0, 2, 0.5, &obs), 4u);
  EXPECT_EQ(Indirect(obs, 60.0), 31u);
  EXPECT_EQ(Indirect(obs, 120.0), 4u);
}

// A coarse sweep over rows 200-209 (110 px between frames, columns 0, 2, .. 18), and a
// reflection that runs along the rows, lit in frame 0 (corpus 5050, scene 130: a mirror image of
// the projector lights the part with a stripe along the rows, which the column scan finds and
// which triangulates 30-50 mm in front of it): on every row it crosses, it sits between frames 7
// and 8 at frame 0's column. A face the light grazes, found by the column scan between the same
// frames at a column between theirs, fits the order and stays.
TEST(RejectAcrossOrder, AReflectionAlongTheRowsIsOutOfOrderWithTheRowsDirectLight) {
  std::vector<SweepObservation> obs;
  for (int y = 200; y <= 209; ++y) AddTrace(&obs, y, 0, 9, 100.0, 110.0, 0.0, 120.0);
  const auto cross = [&](double x, double y, double column, double amplitude) {
    SweepObservation o;
    o.stripe.axis = ScanAxis::kColumn;
    o.stripe.x_px = x, o.stripe.y_px = y, o.stripe.amplitude_dn = amplitude;
    o.column = column;
    obs.push_back(o);
  };
  for (int x = 880; x < 940; ++x) cross(x, 204.3 + 0.05 * (x - 880), 0.0, 60.0);  // reflection
  for (int x = 880; x < 900; ++x) cross(x, 206.4, 14.5, 90.0);                    // grazing face
  cross(300.0, 250.0, 0.0, 70.0);  // on a row without direct light: nothing to judge by
  EXPECT_EQ(RejectAcrossOrder(+1.0, 0.0, 1.0, &obs), 60u);
  EXPECT_EQ(Indirect(obs, 60.0), 60u);
  EXPECT_EQ(Indirect(obs, 90.0), 0u);
  EXPECT_EQ(Indirect(obs, 70.0), 0u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);  // the rows' own order is RejectOutOfOrder's
  // Direction known on both axes or on none: no epipolar axis to order against.
  for (auto& o : obs) o.indirect = false;
  EXPECT_EQ(RejectAcrossOrder(+1.0, -1.0, 1.0, &obs), 0u);
  EXPECT_EQ(RejectAcrossOrder(0.0, 0.0, 1.0, &obs), 0u);
  // The probe turned: the columns are the epipolar lines, the row scan's finds are the cross ones.
  for (auto& o : obs) {
    std::swap(o.stripe.x_px, o.stripe.y_px);
    o.stripe.axis = o.stripe.axis == ScanAxis::kRow ? ScanAxis::kColumn : ScanAxis::kRow;
  }
  EXPECT_EQ(RejectAcrossOrder(0.0, +1.0, 1.0, &obs), 60u);
  EXPECT_EQ(Indirect(obs, 60.0), 60u);
}

// A reflection standing still in the image while the sweep moves on lights one pixel from
// sheets millimetres apart along its ray: none of them can be told direct, all go. Neighbouring
// frames of a fine sweep lighting one pixel of one surface agree on its depth: they stay.
// Corpus 7272 scene 19 in small: a reflection lights a row alone through frames 0-4 (the sheet
// has not reached the part), then the direct stripe, over-exposed and so only evidence, sweeps
// the same pixels in frames 10-13 and is measured beyond them. The reflection goes; the direct
// points beyond stay; evidence is never marked (it is no point).
TEST(RejectSweptTwice, ALineLitAloneByAReflectionThatTheStripeSweptLaterGoes) {
  constexpr double kReflection = 60.0, kDirect = 120.0, kClipped = 247.0, kElsewhere = 100.0;
  std::vector<SweepObservation> obs, evidence;
  AddTrace(&obs, 100, 0, 16, 300.0, 30.0, 0.0, kElsewhere);  // every frame's sheet lit somewhere
  AddTrace(&obs, 200, 0, 4, 470.0, 8.0, 0.0, kReflection);   // 470 .. 502 px
  for (const double x : {440.0, 490.0, 530.0, 566.0}) {      // frames 10-13
    AddTrace(&evidence, 200, 10 + static_cast<int>(evidence.size()),
             10 + static_cast<int>(evidence.size()), x, 0.0, 0.0, kClipped);
  }
  AddTrace(&obs, 200, 14, 16, 596.0, 30.0, 0.0, kDirect);
  EXPECT_EQ(RejectSweptTwice(+1.0, 0.0, evidence, SweptOptions{}, &obs), 5u);
  EXPECT_EQ(Indirect(obs, kReflection), 5u);
  EXPECT_EQ(Indirect(obs, kDirect) + Indirect(obs, kElsewhere), 0u);
  // The scan axis without a direction is not judged.
  for (auto& o : obs) o.indirect = false;
  EXPECT_EQ(RejectSweptTwice(0.0, +1.0, evidence, SweptOptions{}, &obs), 0u);
  // Sheets further apart on the line than max_step_px sweep nothing between them.
  const SweptOptions o;
  std::vector<SweepObservation> coarse;
  AddTrace(&coarse, 200, 10, 13, 300.0, o.max_step_px + 10.0, 0.0, kClipped);
  EXPECT_EQ(RejectSweptTwice(+1.0, 0.0, coarse, o, &obs), 0u);
}

// Corpus 7373 scene 182 in small: the over-exposed stripe (evidence at full scale) crosses the
// row in frames 3-4 and leaves the part; a reflection walks back through frames 7-8 where nothing
// held orders it. Behind the clipped stripe's last place, it goes; a direct point ahead stays;
// evidence not at full scale (a one-pixel spike far along the line) orders nothing.
TEST(RejectBehindClippedLight, APointBehindWhereTheClippedStripeWasGoes) {
  constexpr double kReflection = 60.0, kDirect = 120.0, kClipped = 247.0;
  std::vector<SweepObservation> obs, evidence;
  AddTrace(&evidence, 450, 3, 4, 600.0, 117.0, 0.0, kClipped);  // 600, 717 px
  for (auto& e : evidence) e.stripe.full_scale = true;
  AddTrace(&obs, 450, 7, 8, 541.0, -82.0, 0.0, kReflection);  // 541, 459 px
  AddTrace(&obs, 450, 5, 5, 760.0, 0.0, 0.0, kDirect);
  EXPECT_EQ(RejectBehindClippedLight(+1.0, 0.0, evidence, 1.0, &obs), 2u);
  EXPECT_EQ(Indirect(obs, kReflection), 2u);
  EXPECT_EQ(Indirect(obs, kDirect), 0u);
  // The sheets numbered the other way round (the light moves against the column): the same.
  for (auto& o : obs) o.indirect = false, o.column = -o.column;
  for (auto& e : evidence) e.column = -e.column;
  EXPECT_EQ(RejectBehindClippedLight(-1.0, 0.0, evidence, 1.0, &obs), 2u);
  EXPECT_EQ(Indirect(obs, kReflection), 2u);
  // A spike not at full scale orders nothing.
  for (auto& o : obs) o.indirect = false;
  std::vector<SweepObservation> spike;
  AddTrace(&spike, 450, 0, 0, 1000.0, 0.0, 0.0, kClipped);
  EXPECT_EQ(RejectBehindClippedLight(+1.0, 0.0, spike, 1.0, &obs), 0u);
}

// A fine sweep (0.3 px a frame, centres scattering +-0.4 px) lights each pixel in several
// neighbouring frames, and a face beside a pin jumps once: nothing was lit twice.
TEST(RejectSweptTwice, AFineSweepAndAnOccludingEdgeAreLitOnce) {
  std::vector<SweepObservation> fine;
  AddTrace(&fine, 3, 0, 60, 500.0, 0.3, 0.0, 100.0);
  for (std::size_t i = 0; i < fine.size(); i += 2) fine[i].stripe.x_px -= 0.8;
  EXPECT_EQ(RejectSweptTwice(+1.0, 0.0, {}, SweptOptions{}, &fine), 0u);
  std::vector<SweepObservation> edge;
  AddTrace(&edge, 9, 0, 9, 300.0, 12.0, 0.0, 100.0);
  for (std::size_t i = 5; i < edge.size(); ++i) edge[i].stripe.x_px += 30.0;
  EXPECT_EQ(RejectSweptTwice(+1.0, 0.0, {}, SweptOptions{}, &edge), 0u);
}

TEST(RejectRayConflicts, OnePixelLitFromSheetsFarApartLosesAllAndOneSurfaceStays) {
  const ProbeModel m =
      LoadProbeModel(mlp::test::SourceDir() + "/samples/probes/reference_probe.json");
  // The pixel where the sheet of `column` meets a face at z = 120 mm on the image's middle row.
  const double y = m.camera.cy_px;
  const auto pixel_of = [&](double column) {
    Vec3 n;
    double d = 0.0;
    m.projector.PlaneOf(column, &n, &d);
    return m.camera.Project(Vec3((d - n.z() * 120.0) / n.x(), 0.0, 120.0)).x();
  };
  std::vector<SweepObservation> obs;
  const double still_px = pixel_of(1000.0);
  for (int f = 0; f < 5; ++f) {  // the standing reflection, at columns 600 .. 1400
    SweepObservation o;
    o.stripe.x_px = still_px, o.stripe.y_px = y, o.stripe.amplitude_dn = 60.0;
    o.column = 600.0 + 200.0 * f, o.frame = f;
    obs.push_back(o);
  }
  for (int f = 0; f < 3; ++f) {  // the face lit at columns 2000.0, 2000.1, 2000.2
    SweepObservation o;
    o.column = 2000.0 + 0.1 * f;
    o.stripe.x_px = pixel_of(o.column), o.stripe.y_px = y, o.stripe.amplitude_dn = 120.0;
    o.frame = 10 + f;
    obs.push_back(o);
  }
  ASSERT_EQ(std::lround(obs[5].stripe.x_px), std::lround(obs[7].stripe.x_px));
  EXPECT_EQ(RejectRayConflicts(m, RayOptions{}, &obs), 5u);
  EXPECT_EQ(Indirect(obs, 60.0), 5u);
  EXPECT_EQ(Indirect(obs, 120.0), 0u);
}

}  // namespace
}  // namespace mlp::probe_fw
