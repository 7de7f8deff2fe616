// Profile error during curve grinding (seed 001) against the frame generator's truth: a seeded
// sweep of injected machine errors (offsets out and in, a worn nose, none) at points along a
// profile of lines and arcs, each classified, its error recovered and its compensation as
// the seed says; a stroke that did not cut; bad input refused; the job file read back.

#include "mlp/grind/grind_job.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

namespace mlp::grind {
namespace {

using geometry::Vec2;
constexpr double kPxMm = 0.005;             // the camera's pixel on the object
constexpr double kDTolMm = 0.2 * kPxMm;     // d sub-pixel: 1 um
constexpr double kDirTolDeg = 2.0;          // issue 8: the error's direction
constexpr double kSizeTolMm = kPxMm;        // and size within a pixel
constexpr double kNuisanceDirTolDeg = 5.0;  // issue 55: with a droplet or burr on the edge

double AngleDeg(const Vec2& a, const Vec2& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

// The case's frames, rendered, and the measurement's input on them.
struct CaseFrames {
  CaseFrames(const geometry::Profile2& p, const GrindJob& job, const ErrorCase& c, unsigned seed) {
    RenderCase(p, job, c, seed, &before, &after);
    in = {{before.data(), job.camera.width_px, job.camera.height_px},
          {after.data(), job.camera.width_px, job.camera.height_px},
          c.c_mm,
          c.mi_mm};
  }
  CaseFrames(const CaseFrames&) = delete;  // `in` points into the frames
  CaseFrames& operator=(const CaseFrames&) = delete;
  std::vector<std::uint8_t> before, after;
  PointInput in;
};

PointResult Measure(const geometry::Profile2& p,
                    const GrindJob& job,
                    const ErrorCase& c,
                    unsigned seed) {
  const CaseFrames f(p, job, c, seed);
  return MeasurePoint(f.in, p, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
}

TEST(Grind, ASeededSweepIsClassifiedAndItsErrorsRecovered) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  const std::vector<ErrorCase> cases = SweepCases(p, job.wheel_radius_mm, job.limit_mm, 32, 7);
  double worst_d = 0, worst_dir = 0, worst_size = 0, worst_comp = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const ErrorCase& c = cases[i];
    const PointResult r = Measure(p, job, c, 100 + 2 * static_cast<unsigned>(i));
    const std::string what = "case " + std::to_string(i) + " (" + ToString(c.feed) + ")";
    ASSERT_EQ(r.feed, c.feed) << what << ": d " << r.d_mm * 1e3 << " um, true " << c.d_mm * 1e3;
    EXPECT_NEAR(r.d_mm, c.d_mm, kDTolMm) << what;
    worst_d = std::max(worst_d, std::abs(r.d_mm - c.d_mm));
    const Vec2 n = p.Closest(c.mi_mm).normal;
    if (c.feed == Feed::kUnderFeed) {
      EXPECT_TRUE(r.wheel_cut) << what;
      EXPECT_LT(AngleDeg(r.error_dir, c.error_dir), kDirTolDeg) << what;
      EXPECT_NEAR(r.error_mm, c.error_mm, kSizeTolMm) << what;
      EXPECT_LT((r.compensation_mm + r.error_dir * r.error_mm).norm(), 1e-12) << what;
      worst_dir = std::max(worst_dir, AngleDeg(r.error_dir, c.error_dir));
      worst_size = std::max(worst_size, std::abs(r.error_mm - c.error_mm));
    } else if (c.feed == Feed::kOverFeed) {  // along the normal, the over-cut + 2 e
      const Vec2 want = n * (c.d_mm + 2 * job.limit_mm);
      EXPECT_LT((r.compensation_mm - want).norm(), kSizeTolMm) << what;
      worst_comp = std::max(worst_comp, (r.compensation_mm - want).norm());
    } else {
      EXPECT_EQ(r.compensation_mm.norm(), 0.0) << what;
    }
  }
  std::printf(
      "32 cases: all classified right; d within %.2f um; under-feed direction within %.2f deg, "
      "size within %.2f um; over-feed compensation within %.2f um\n",
      worst_d * 1e3, worst_dir, worst_size * 1e3, worst_comp * 1e3);
}

// Every 5th point of a whole pass (strokes every 0.1 mm along the profile, each overlapping the
// last, only a sliver of the nose's arc new each time), each stroke's wheel `offset` off its
// place with its nose `nose_mm`, measured from the frames before and after its stroke.
struct PassPoint {
  geometry::ProfileFoot foot;
  PointResult result;
};

std::vector<PassPoint> MeasureAPass(const GrindJob& job,
                                    const geometry::Profile2& p,
                                    const Vec2& offset,
                                    double nose_mm,
                                    unsigned seed) {
  std::vector<WheelStroke> strokes;
  std::vector<PassPoint> out;
  int k = 0;
  for (double s = 0.3; s < p.Length() - 0.3; s += 0.1, ++k) {
    const geometry::ProfileFoot f = p.At(s);
    const Vec2 c = f.point + job.wheel_radius_mm * f.normal;
    const std::vector<WheelStroke> before = strokes;
    strokes.push_back({c + offset, nose_mm});
    if (k % 5 != 0) continue;
    const unsigned frame_seed = seed + static_cast<unsigned>(k);
    const auto b = RenderGrindFrame(p, job.stock_mm, before, job.camera, frame_seed);
    const auto a = RenderGrindFrame(p, job.stock_mm, strokes, job.camera, frame_seed + 1);
    const PointInput in{{b.data(), job.camera.width_px, job.camera.height_px},
                        {a.data(), job.camera.width_px, job.camera.height_px},
                        c,
                        f.point};
    out.push_back({f, MeasurePoint(in, p, job.camera, job.wheel_radius_mm, job.limit_mm)});
  }
  return out;
}

// The wheel 30 um off at 80 deg throughout the pass.
TEST(Grind, OverlappingStrokesOfAWholePassStillShowTheWheelsError) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  const Vec2 offset = 0.03 * Vec2(std::cos(80 * M_PI / 180), std::sin(80 * M_PI / 180));
  double worst_dir = 0, worst_size = 0;
  const std::vector<PassPoint> pass = MeasureAPass(job, p, offset, job.wheel_radius_mm, 10);
  for (const PassPoint& pt : pass) {
    const PointResult& r = pt.result;
    ASSERT_EQ(r.feed, Feed::kUnderFeed) << "at " << pt.foot.point.transpose();
    EXPECT_LT(AngleDeg(r.error_dir, offset), kDirTolDeg) << "at " << pt.foot.point.transpose();
    EXPECT_NEAR(r.error_mm, offset.norm(), kSizeTolMm) << "at " << pt.foot.point.transpose();
    worst_dir = std::max(worst_dir, AngleDeg(r.error_dir, offset));
    worst_size = std::max(worst_size, std::abs(r.error_mm - offset.norm()));
  }
  std::printf("a whole pass, %zu points measured: direction within %.2f deg, size within %.2f um\n",
              pass.size(), worst_dir, worst_size * 1e3);
  EXPECT_GE(pass.size(), 9U);
}

// The same pass with the nose worn 17 um smaller and the wheel where it should be: each stroke's
// new arc lies on one side of the normal, where a shift of the nose explains it as well as the
// wear does, to within the edge's noise; fitted as a shift, the error leaned towards that side
// (the outside renderer's worn noses: 5-17 deg off the normal on 30 of 198 directions). The error
// is the lost radius, along the normal, whether its direction is said determined or not.
TEST(Grind, AWornNoseOverAWholePassIsTheNormal) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  constexpr double kWearMm = 0.017;
  int determined = 0;
  double worst_dir = 0, worst_size = 0;
  const std::vector<PassPoint> pass =
      MeasureAPass(job, p, Vec2::Zero(), job.wheel_radius_mm - kWearMm, 30);
  for (const PassPoint& pt : pass) {
    const PointResult& r = pt.result;
    ASSERT_EQ(r.feed, Feed::kUnderFeed) << "at " << pt.foot.point.transpose();
    EXPECT_LT(AngleDeg(r.error_dir, pt.foot.normal), kNuisanceDirTolDeg)
        << "at " << pt.foot.point.transpose();
    EXPECT_NEAR(r.error_mm, kWearMm, kSizeTolMm) << "at " << pt.foot.point.transpose();
    worst_dir = std::max(worst_dir, AngleDeg(r.error_dir, pt.foot.normal));
    worst_size = std::max(worst_size, std::abs(r.error_mm - kWearMm));
    determined += r.direction_determined ? 1 : 0;
  }
  std::printf(
      "a worn nose over a whole pass, %zu points measured (%d directions determined): within "
      "%.2f deg of the normal, size within %.2f um\n",
      pass.size(), determined, worst_dir, worst_size * 1e3);
  EXPECT_GE(pass.size(), 9U);
}

// Seed 001's double-bevel wheel (flanks 35 deg from its axis, its tip down): the nose's arc
// spans +-55 deg, so on the profile's flank and arcs the flanks cut too and the removed
// region's edge is part flank. A seeded sweep measured against the wheel's edge; the same
// frames measured as if the nose were round show the flanks matter.
TEST(Grind, ADoubleBevelWheelsErrorIsMeasuredToItsEdge) {
  GrindJob job;
  job.profile = DemoProfile();
  job.bevel.on = true;
  job.bevel.half_angle_deg = 35;
  const geometry::Profile2 p(job.profile);
  const std::vector<ErrorCase> cases =
      SweepCases(p, job.wheel_radius_mm, job.limit_mm, 24, 11, job.bevel);
  double worst_d = 0, worst_dir = 0, worst_size = 0, round_worst = 0;
  int round_refused = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const ErrorCase& c = cases[i];
    const unsigned seed = 300 + 2 * static_cast<unsigned>(i);
    const CaseFrames frames(p, job, c, seed);
    const PointResult r =
        MeasurePoint(frames.in, p, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
    const std::string what = "case " + std::to_string(i) + " (" + ToString(c.feed) + ")";
    ASSERT_EQ(r.feed, c.feed) << what << ": d " << r.d_mm * 1e3 << " um, true " << c.d_mm * 1e3;
    EXPECT_NEAR(r.d_mm, c.d_mm, kDTolMm) << what;
    worst_d = std::max(worst_d, std::abs(r.d_mm - c.d_mm));
    if (c.feed != Feed::kUnderFeed) continue;
    EXPECT_LT(AngleDeg(r.error_dir, c.error_dir), kDirTolDeg) << what;
    EXPECT_NEAR(r.error_mm, c.error_mm, kSizeTolMm) << what;
    worst_dir = std::max(worst_dir, AngleDeg(r.error_dir, c.error_dir));
    worst_size = std::max(worst_size, std::abs(r.error_mm - c.error_mm));
    // Measured as a round nose (the wrong wheel): refused (its arc fits no nose of the
    // wheel's radius, or disagrees with the crossing) or off.
    try {
      const PointResult round =
          MeasurePoint(frames.in, p, job.camera, job.wheel_radius_mm, job.limit_mm);
      round_worst = std::max(round_worst,
                             (round.error_dir * round.error_mm - c.error_dir * c.error_mm).norm());
    } catch (const GrindError&) {
      ++round_refused;
    }
  }
  std::printf(
      "double-bevel wheel, 24 cases: all classified right; d within %.2f um; under-feed "
      "direction within %.2f deg, size within %.2f um; measured as a round nose: %d refused, "
      "the rest off by up to %.2f um\n",
      worst_d * 1e3, worst_dir, worst_size * 1e3, round_refused, round_worst * 1e3);
  // The flanks matter: a round nose misreads them, now refused where its evidence disagrees.
  EXPECT_TRUE(round_worst > 3 * kSizeTolMm || round_refused > 0);
}

// Issue 55: a droplet (a dark disc in the back light) on the freshly cut arc, beside C-Mi,
// in each seeded under-feed case: the removed region's edge then holds points no wheel
// position explains. Each point is refused, or its error stays the wheel's (never a
// compensation pulled by the droplet: before, 38-253 um at 135-150 deg from the normal on an
// outside renderer, where the truth was 13 um).
TEST(Grind, ADropletOnTheCutArcIsRefusedOrLeftOut) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  const std::vector<ErrorCase> cases = SweepCases(p, job.wheel_radius_mm, job.limit_mm, 32, 55);
  int under = 0, refused = 0;
  double worst_dir = 0, worst_size = 0;
  for (size_t i = 0; i < cases.size(); ++i) {
    const ErrorCase& c = cases[i];
    if (c.feed != Feed::kUnderFeed) continue;
    ++under;
    CaseFrames f(p, job, c, 500 + 2 * static_cast<unsigned>(i));
    // A 40 um droplet centred on the cut arc 0.15 mm along the profile from Mi.
    const geometry::ProfileFoot foot = p.Closest(c.mi_mm);
    const Vec2 along(foot.normal.y(), -foot.normal.x());
    const Vec2 centre = job.camera.ToPx(c.mi_mm + 0.15 * along + c.d_mm * foot.normal);
    const double radius_px = 0.040 / kPxMm;
    for (int v = 0; v < job.camera.height_px; ++v)
      for (int u = 0; u < job.camera.width_px; ++u)
        if ((Vec2(u, v) - centre).norm() < radius_px)
          f.after[static_cast<size_t>(v) * job.camera.width_px + u] =
              static_cast<std::uint8_t>(job.camera.dark);
    const std::string what = "case " + std::to_string(i);
    try {
      const PointResult r =
          MeasurePoint(f.in, p, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
      EXPECT_GT(r.left_out, 0) << what;                  // the droplet's points found and left out
      EXPECT_EQ(r.compensation_mm.norm(), 0.0) << what;  // and nothing acts on the point
      EXPECT_NE(r.compensation_withheld.find("not compensated"), std::string::npos) << what;
      worst_dir = std::max(worst_dir, AngleDeg(r.error_dir, c.error_dir));
      worst_size = std::max(worst_size, std::abs(r.error_mm - c.error_mm));
      EXPECT_LT(AngleDeg(r.error_dir, c.error_dir), kNuisanceDirTolDeg) << what;
      EXPECT_NEAR(r.error_mm, c.error_mm, kSizeTolMm) << what;
    } catch (const GrindError& e) {
      ++refused;
      EXPECT_NE(std::string(e.what()).find("not compensated"), std::string::npos) << e.what();
    }
  }
  std::printf(
      "a droplet on the cut arc: %d under-feed points, %d refused, the rest within "
      "%.2f deg and %.2f um\n",
      under, refused, worst_dir, worst_size * 1e3);
  EXPECT_GT(under, 4);
}

// A stroke 0.2 mm out (more than the 0.15 mm of stock): nothing removed; an under-feed by the
// stock, along the normal.
TEST(Grind, AStrokeThatDidNotCutGivesTheNormalAndTheExcess) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  ErrorCase c;
  const geometry::ProfileFoot f = p.At(0.8);
  c.mi_mm = f.point, c.c_mm = f.point + job.wheel_radius_mm * f.normal;
  c.offset_mm = 0.2 * f.normal;
  const PointResult r = Measure(p, job, c, 7);
  EXPECT_EQ(r.feed, Feed::kUnderFeed);
  EXPECT_FALSE(r.wheel_cut);
  EXPECT_NEAR(r.d_mm, job.stock_mm, kDTolMm);
  EXPECT_LT((r.compensation_mm + f.normal * r.d_mm).norm(), 1e-12);
}

// The point `along_mm` along the profile with the wheel `gouge_mm` past the nominal.
ErrorCase OverCut(const geometry::Profile2& p,
                  const GrindJob& job,
                  double along_mm,
                  double gouge_mm) {
  const geometry::ProfileFoot f = p.At(along_mm);
  ErrorCase c;
  c.mi_mm = f.point, c.c_mm = f.point + job.wheel_radius_mm * f.normal;
  c.offset_mm = -gouge_mm * f.normal;
  return c;
}

// A gouge deeper than the 0.4 mm searched beyond Mi is measured where the frame's own edge on
// C-Mi confirms the seed's search (issue 55: the outside renderer's over-cuts of 404 and 478 um
// were refused); past 1 mm it is refused, never compensated.
TEST(Grind, AGougePastTheWindowIsMeasuredWhereTheFrameShowsIt) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  constexpr double kGougeMm = 0.47;
  ErrorCase c = OverCut(p, job, 0.8, kGougeMm);
  const PointResult r = Measure(p, job, c, 11);
  EXPECT_EQ(r.feed, Feed::kOverFeed);
  EXPECT_NEAR(r.d_mm, kGougeMm, kDTolMm);
  c = OverCut(p, job, 0.8, 1.2);
  try {
    Measure(p, job, c, 11);
    ADD_FAILURE() << "a gouge of 1.2 mm was measured";
  } catch (const GrindError& e) {
    EXPECT_NE(std::string(e.what()).find("not compensated"), std::string::npos) << e.what();
  }
}

// A dark arc painted into the after frame: all points between `inner_mm` and `inner_mm` +
// `width_mm` from `centre_mm` (a thin dark band concentric with the wheel, as the defocused
// wheel's shadow edge lay on the outside renderer's top-of-stroke frames).
void PaintRing(
    const GrindJob& job, const Vec2& centre_mm, double inner_mm, double width_mm, CaseFrames* f) {
  // Each pixel darkened by the share of its 8 x 8 sub-samples inside (a hard-edged ring's
  // pixel steps alone were bumps of 3 um to the edge's bump test).
  constexpr int kSub = 8;
  const Vec2 centre = job.camera.ToPx(centre_mm);
  for (int v = 0; v < job.camera.height_px; ++v)
    for (int u = 0; u < job.camera.width_px; ++u) {
      if (std::abs((Vec2(u, v) - centre).norm() * kPxMm - inner_mm - width_mm / 2) >
          width_mm / 2 + 2 * kPxMm)
        continue;
      int inside = 0;
      for (int i = 0; i < kSub; ++i)
        for (int j = 0; j < kSub; ++j) {
          const Vec2 at(u + (i + 0.5) / kSub - 0.5, v + (j + 0.5) / kSub - 0.5);
          const double r_mm = (at - centre).norm() * kPxMm;
          inside += r_mm >= inner_mm && r_mm < inner_mm + width_mm;
        }
      std::uint8_t& px = f->after[static_cast<size_t>(v) * job.camera.width_px + u];
      const double share = static_cast<double>(inside) / (kSub * kSub);
      px = static_cast<std::uint8_t>(std::lround(px * (1 - share) + job.camera.dark * share));
    }
}

// Issue 55: a speck in the light on C-Mi before the part (dark, then light again within
// 0.15 mm: here a 20 um dark band round the wheel 0.15 mm before a 0.2 mm over-cut's edge) is
// passed over and said, the over-cut measured; a second one where the part's edge is looked
// for refuses the point. Before, the first was refused ("the first material on C-Mi is a
// speck"), as the outside renderer's over-cuts were where the defocused wheel's soft shadow
// came first on the line (seed 9203 in the corpus test).
TEST(Grind, ASpeckInTheLightOnCMiIsPassedOverToThePart) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  constexpr double kGougeMm = 0.2, kSpeckBeforeMm = 0.15, kSpeckWidthMm = 0.02;
  const ErrorCase c = OverCut(p, job, 0.8, kGougeMm);
  const double ti = job.wheel_radius_mm;
  CaseFrames f(p, job, c, 13);
  PaintRing(job, c.c_mm, ti + kGougeMm - kSpeckBeforeMm, kSpeckWidthMm, &f);
  const PointResult r =
      MeasurePoint(f.in, p, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
  std::printf("a speck on C-Mi: d %.4f mm (truth %.4f), passed %.4f mm before the part\n", r.d_mm,
              kGougeMm, r.speck_passed_mm);
  EXPECT_EQ(r.feed, Feed::kOverFeed);
  EXPECT_NEAR(r.d_mm, kGougeMm, kDTolMm);
  EXPECT_NEAR(r.speck_passed_mm, kSpeckBeforeMm, 2 * kPxMm);
  // A second one 60 um beyond the first, where the part's edge would be looked for.
  PaintRing(job, c.c_mm, ti + kGougeMm - kSpeckBeforeMm + 0.06, kSpeckWidthMm, &f);
  try {
    MeasurePoint(f.in, p, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
    ADD_FAILURE() << "two specks on C-Mi were measured through";
  } catch (const GrindError& e) {
    EXPECT_NE(std::string(e.what()).find("not compensated"), std::string::npos) << e.what();
  }
}

// The seed's six search cases (Fig. 3) and its one-column case, each met on purpose: a groove
// whose flanks face right (C in a later column than Mi: cases 1-3) and left (4-6) and whose
// flats put C over Mi (0); the material everywhere the nominal plus k, so Mr = Mi + k n
// exactly on the flats and flanks: k past the nose's radius (the contour beyond C), inside it
// (between C and Mi) and below the nominal (beyond Mi).
TEST(Grind, TheSeedsSixSearchCasesEachFindMr) {
  const double s2 = std::sqrt(0.5);
  const std::vector<geometry::ProfileSegment> groove = {
      {Vec2(0.05, 2.5), Vec2(1.0, 2.5), false, Vec2::Zero(), true},
      {Vec2(1.0, 2.5), Vec2(2.0, 1.5), false, Vec2::Zero(), true},
      {Vec2(2.0, 1.5), Vec2(3.0, 1.5), false, Vec2::Zero(), true},
      {Vec2(3.0, 1.5), Vec2(4.0, 2.5), false, Vec2::Zero(), true},
      {Vec2(4.0, 2.5), Vec2(5.0, 2.5), false, Vec2::Zero(), true}};
  const geometry::Profile2 p(groove);
  const GrindCamera cam;
  constexpr double kNoseMm = 0.3, kLimitMm = 0.01;
  struct Where {
    Vec2 mi, n;
    int cases[3];  // beyond C, between, beyond Mi
  };
  const Where where[] = {{Vec2(1.5, 2.0), Vec2(s2, s2), {1, 2, 3}},
                         {Vec2(3.5, 2.0), Vec2(-s2, s2), {4, 5, 6}},
                         {Vec2(2.5, 1.5), Vec2(0, 1), {0, 0, 0}}};
  const double stock_mm[3] = {0.4, 0.15, -0.1};
  std::vector<int> seen;
  double worst = 0;
  for (int k = 0; k < 3; ++k) {
    const auto frame = RenderGrindFrame(p, stock_mm[k], {}, cam, 40 + static_cast<unsigned>(k));
    const geometry::GreyView view{frame.data(), cam.width_px, cam.height_px};
    for (const Where& w : where) {
      const PointResult r =
          MeasurePoint({view, view, w.mi + kNoseMm * w.n, w.mi}, p, cam, kNoseMm, kLimitMm);
      const Vec2 mr_true = w.mi + stock_mm[k] * w.n;
      EXPECT_EQ(r.search_case, w.cases[k]) << "k " << stock_mm[k];
      EXPECT_FALSE(r.search_by_rows);
      EXPECT_LT((r.mr_mm - mr_true).norm(), kDTolMm) << "case " << w.cases[k];
      EXPECT_EQ(r.feed, stock_mm[k] > 0 ? Feed::kUnderFeed : Feed::kOverFeed);
      worst = std::max(worst, (r.mr_mm - mr_true).norm());
      seen.push_back(r.search_case);
    }
  }
  std::sort(seen.begin(), seen.end());
  EXPECT_EQ(seen, (std::vector<int>{0, 0, 0, 1, 2, 3, 4, 5, 6}));
  std::printf("the seed's six search cases and the one-column case: Mr within %.3f um\n",
              worst * 1e3);
}

// A contour steeper than 45 deg: the rows play the columns' part (the seed's column sort
// cannot follow a wall); a step whose wall is 80 deg from the flat.
TEST(Grind, ASteepWallIsSearchedAlongTheRows) {
  const Vec2 wall_dir = Vec2(std::cos(-80 * M_PI / 180), std::sin(-80 * M_PI / 180));
  const Vec2 top_end(2.4, 2.8), wall_end = top_end + 1.6 * wall_dir;
  const std::vector<geometry::ProfileSegment> step = {
      {Vec2(0.05, 2.8), top_end, false, Vec2::Zero(), true},
      {top_end, wall_end, false, Vec2::Zero(), true},
      {wall_end, Vec2(5.0, wall_end.y()), false, Vec2::Zero(), true}};
  const geometry::Profile2 p(step);
  const GrindCamera cam;
  constexpr double kNoseMm = 0.3, kLimitMm = 0.01, kStockMm = 0.05;
  const auto frame = RenderGrindFrame(p, kStockMm, {}, cam, 50);
  const geometry::GreyView view{frame.data(), cam.width_px, cam.height_px};
  const geometry::ProfileFoot f = p.Closest(top_end + 0.8 * wall_dir);
  const PointResult r =
      MeasurePoint({view, view, f.point + kNoseMm * f.normal, f.point}, p, cam, kNoseMm, kLimitMm);
  EXPECT_TRUE(r.search_by_rows);
  EXPECT_EQ(r.search_case, 5);  // between: C's row above Mi's (rows grow downwards)
  EXPECT_LT((r.mr_mm - (f.point + kStockMm * f.normal)).norm(), kDTolMm);
}

// A point whose Mi the camera does not see is refused as that, with the side and how far, not
// as a part without contour (outside renderer seed 9237: Mi 2-79 px beyond the right edge).
TEST(Grind, SaysWhenMiIsOutsideTheFrame) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  const GrindCamera& cam = job.camera;
  std::vector<std::uint8_t> light(static_cast<size_t>(cam.width_px * cam.height_px), 210);
  const geometry::GreyView blank{light.data(), cam.width_px, cam.height_px};
  constexpr double kBeyondPx = 30;
  const Vec2 mi = cam.ToMm(Vec2(cam.width_px - 1 + kBeyondPx, cam.height_px / 2.0));
  try {
    MeasurePoint({blank, blank, mi + Vec2(-1, 0), mi}, p, cam, 1.0, 0.01);
    ADD_FAILURE() << "a point outside the frame was measured";
  } catch (const GrindError& e) {
    EXPECT_NE(std::string(e.what()).find("Mi lies 30 px beyond the frame's right edge"),
              std::string::npos)
        << e.what();
  }
}

// An edge found only by extrapolating the contour past the frame's last column is not measured
// (outside renderer seed 9590 point 3: Mi and Mr 3 px beyond the right edge, d 1.76 um off): a
// flat part whose edge runs out of the frame, Mi 3 px past it, is refused as outside the view.
TEST(Grind, SaysWhenTheEdgeFoundIsOutsideTheFrame) {
  const GrindCamera cam;
  const double right_mm = cam.ToMm(Vec2(cam.width_px - 1, 0)).x();
  const double y_mm = cam.ToMm(Vec2(0, cam.height_px / 2.0)).y();
  const geometry::Profile2 flat(std::vector<geometry::ProfileSegment>{
      {Vec2(0.05, y_mm), Vec2(right_mm + 1.0, y_mm), false, Vec2::Zero(), true}});
  constexpr double kNoseMm = 0.3, kLimitMm = 0.01, kStockMm = 0.02, kBeyondPx = 3;
  const auto frame = RenderGrindFrame(flat, kStockMm, {}, cam, 50);
  const geometry::GreyView view{frame.data(), cam.width_px, cam.height_px};
  const geometry::ProfileFoot f = flat.Closest(Vec2(right_mm + kBeyondPx * cam.mm_per_px, y_mm));
  try {
    const PointResult r = MeasurePoint({view, view, f.point + kNoseMm * f.normal, f.point}, flat,
                                       cam, kNoseMm, kLimitMm);
    ADD_FAILURE() << "an edge outside the frame was measured: Mr " << r.mr_mm.transpose();
  } catch (const GrindError& e) {
    EXPECT_NE(std::string(e.what()).find("Mr lies 3 px beyond the frame's right edge"),
              std::string::npos)
        << e.what();
  }
  // 10 px inside the frame the same edge is measured, to the stock.
  const geometry::ProfileFoot in = flat.Closest(Vec2(right_mm - 10 * cam.mm_per_px, y_mm));
  const PointResult r = MeasurePoint({view, view, in.point + kNoseMm * in.normal, in.point}, flat,
                                     cam, kNoseMm, kLimitMm);
  EXPECT_NEAR(r.d_mm, kStockMm, kDTolMm);
}

TEST(Grind, RefusesWhatItCannotMeasure) {
  GrindJob job;
  job.profile = DemoProfile();
  const geometry::Profile2 p(job.profile);
  std::vector<std::uint8_t> small(100, 0);
  const geometry::GreyView tiny{small.data(), 10, 10};
  const Vec2 mi = p.At(1.0).point;
  EXPECT_THROW(MeasurePoint({tiny, tiny, mi + Vec2(0, 1), mi}, p, job.camera, 1.0, 0.01),
               GrindInputError);  // frames that are not the camera's
  std::vector<std::uint8_t> light(static_cast<size_t>(1024 * 768), 210);
  const geometry::GreyView blank{light.data(), 1024, 768};
  EXPECT_THROW(MeasurePoint({blank, blank, mi + Vec2(0, 1), mi}, p, job.camera, 1.0, 0.01),
               GrindError);  // no contour near Mi
  EXPECT_THROW(MeasurePoint({blank, blank, mi, mi}, p, job.camera, 1.0, 0.01), GrindInputError);
  EXPECT_THROW(ParseJob("{\"format\": \"mlprobe-grind/1\"}"), GrindInputError);
  // A profile with a gap is the job file's fault, named with the file.
  GrindJob gap = job;
  gap.profile = DemoProfile();
  gap.profile[1].start += Vec2(0.2, 0);
  try {
    ParseJob(JobJson(gap), "/shop/grind/job.json");
    ADD_FAILURE() << "a profile with a gap was read";
  } catch (const GrindInputError& e) {
    EXPECT_NE(std::string(e.what()).find("/shop/grind/job.json: profile"), std::string::npos)
        << e.what();
  }
}

TEST(Grind, AJobFileReadsBack) {
  GrindJob job;
  job.profile = DemoProfile();
  job.points.push_back({"b.pgm", "a.pgm", Vec2(1, 3), Vec2(1, 2)});
  job.bevel.on = true;
  job.bevel.half_angle_deg = 35;
  job.bevel.tip_dir = Vec2(0.6, -0.8);
  const GrindJob back = ParseJob(JobJson(job));
  EXPECT_TRUE(back.bevel.on);
  EXPECT_EQ(back.bevel.half_angle_deg, 35);
  EXPECT_EQ(back.bevel.tip_dir, job.bevel.tip_dir);
  GrindJob round = job;
  round.bevel.on = false;
  EXPECT_FALSE(ParseJob(JobJson(round)).bevel.on);  // no bevel: a round nose
  ASSERT_EQ(back.profile.size(), job.profile.size());
  EXPECT_TRUE(back.profile[1].arc);
  EXPECT_FALSE(back.profile[1].ccw);
  constexpr double kReadBackMm = 1e-12;  // the job file read back
  EXPECT_NEAR((back.profile[3].center - job.profile[3].center).norm(), 0, kReadBackMm);
  ASSERT_EQ(back.points.size(), 1u);
  EXPECT_EQ(back.points[0].after, "a.pgm");
  EXPECT_NO_THROW(geometry::Profile2{back.profile});
}

}  // namespace
}  // namespace mlp::grind
