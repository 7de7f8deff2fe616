// The alignment job in-process (issue 53): a plate turned 12 deg on the table, its top face
// and two bores sampled with 2 um noise along their normals (tests/features/feature_points.h,
// seeded), through the same datum -> gate -> changes the service runs.

#include "mlp/jobs/align.h"

#include "mlp/base/check.h"

#include <cmath>

#include "../features/feature_points.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

using features::test::CloudMaker;
using features::test::Dir;
using geometry::Vec3;

constexpr double kNoiseMm = 0.002;
// Hundreds of points a feature at 2 um noise fix a centre to ~0.2 um and a 60 mm baseline's
// turn to well under a millidegree; these bounds are ten times that and more.
constexpr double kOriginTolMm = 0.002;
constexpr double kRotationTolDeg = 0.001;

const CalibrationFacts kCalibration{"cal-1", "MLP-0001", 2.0};

// The plate: top face z = -20; bore B (d 10) at (100, 50), bore C 60 mm from it at 12 deg.
const Vec3 kB(100, 50, -20);
const Vec3 kC = kB + 60 * Dir(12);

Evidence Of(const CloudMaker& m) {
  Evidence e;
  e.points_mcs = m.Cloud();
  e.probe_serial = "MLP-0001";
  return e;
}

FaceInput TopFace(unsigned seed) {
  CloudMaker m(seed, kNoiseMm);
  m.Patch(Vec3(60, 0, -20), Vec3::UnitX(), Vec3::UnitY(), 120, 35, 2000);  // clear of the bores
  FaceInput f;
  f.nominal.point_mcs = Vec3(100, 20, -20.05);  // the nominal 50 um off: the fit finds the face
  f.evidence = Of(m);
  return f;
}

HoleInput Bore(const Vec3& top_centre, unsigned seed) {
  CloudMaker m(seed, kNoiseMm);
  m.Wall(top_centre.x(), top_centre.y(), 5.0, -34, -21.5, 0, 360, 800);
  HoleInput h;
  h.nominal.top_centre_mcs = top_centre + Vec3(0.05, -0.04, 0);  // where the drawing puts it
  h.nominal.diameter_mm = 10.0;
  h.nominal.depth_mm = 15.0;
  h.evidence = Of(m);
  return h;
}

AlignInputs PlaneCircleCircle() {
  AlignInputs in;
  in.method = "plane-circle-circle";
  in.work_offset = 1;
  in.plane_a = TopFace(11);
  in.circle_b = Bore(kB, 12);
  in.circle_c = Bore(kC, 13);
  return in;
}

TEST(AlignJob, PlaneCircleCirclePutsTheOriginOnBoreBAndYTowardsBoreC) {
  const AlignInputs in = PlaneCircleCircle();
  const AlignOutcome o = AssessAlign(in, kCalibration, features::PlausibilityLimits{});
  EXPECT_TRUE(o.refusal.empty()) << o.refusal.front();
  EXPECT_LT((o.work.origin_mm - kB).norm(), kOriginTolMm);
  // Y runs B -> C (12 deg), X = Y x Z: -78 deg.
  EXPECT_NEAR(o.work.rotation_z_deg, 12.0 - 90.0, kRotationTolDeg);
  EXPECT_LT(o.work.tilt_deg, kRotationTolDeg);
  for (const char* name : {"plane_a", "circle_b", "circle_c"})
    EXPECT_NE(Find(o.readings, name), nullptr) << name;
  const auto& b = std::get<Readings>(Find(o.readings, "circle_b")->value);
  EXPECT_NEAR(std::get<double>(Find(b, "diameter_mm")->value), 10.0, kOriginTolMm);

  const nc::NcResult out = AlignChanges(o, in, 4, /*named_parameters=*/true);
  EXPECT_EQ(out.header, "mlprobe job 4: plane-circle-circle alignment");
  ASSERT_EQ(out.work.size(), 1u);
  EXPECT_EQ(out.work[0].index, 1);
  EXPECT_FALSE(out.work[0].incremental);  // absolute: the origin found
  EXPECT_NEAR(out.work[0].after_mm[0], kB.x(), kOriginTolMm);
  ASSERT_TRUE(out.work[0].rotation_after_deg.has_value());
  EXPECT_NEAR(*out.work[0].rotation_after_deg, -78.0, kRotationTolDeg);
  EXPECT_TRUE(out.tools.empty());
}

// 3-2-1 from the touch probe's points: the edge y = 0 of the plate (turned 12 deg about B's
// corner) and the corner's X from a given point.
TEST(AlignJob, PlaneLinePointFromTouchPointsSetsXAlongTheEdge) {
  AlignInputs in;
  in.method = "plane-line-point";
  in.work_offset = 2;
  in.plane_a = TopFace(21);
  in.line_b = TouchPoints{kB + 10 * Dir(12), kB + 70 * Dir(12)};
  in.point_c = GivenPoint{kB + Vec3(0, 0, 3)};  // level with B along X
  const AlignOutcome o = AssessAlign(in, kCalibration, features::PlausibilityLimits{});
  EXPECT_TRUE(o.refusal.empty()) << o.refusal.front();
  EXPECT_LT((o.work.origin_mm - kB).norm(), kOriginTolMm);
  EXPECT_NEAR(o.work.rotation_z_deg, 12.0, kRotationTolDeg);
  const auto& line = std::get<Readings>(Find(o.readings, "line_b")->value);
  EXPECT_NEAR(std::get<double>(Find(line, "span_mm")->value), 60.0, 1e-9);
}

TEST(AlignJob, TouchPointsCloserThanFiveMillimetresAreRefusedAsInput) {
  AlignInputs in;
  in.method = "plane-line-point";
  in.plane_a = TopFace(31);
  in.line_b = TouchPoints{kB, kB + 4.9 * Dir(12)};
  in.point_c = GivenPoint{kB};
  EXPECT_THROW(AssessAlign(in, kCalibration, features::PlausibilityLimits{}), RequestError);
}

TEST(AlignJob, AnOriginFarFromTheExpectedOneIsRefusedAndNothingIsWritten) {
  AlignInputs in = PlaneCircleCircle();
  in.expected_origin_mm = kB + Vec3(8, 0, 0);  // the plate clamped 8 mm from where it should be
  features::PlausibilityLimits limits;
  limits.max_work_shift_mm = 5.0;
  const AlignOutcome o = AssessAlign(in, kCalibration, limits);
  ASSERT_FALSE(o.refusal.empty());
  EXPECT_THROW(AlignChanges(o, in, 5, true), base::CheckFailure);
}

TEST(AlignJob, ABoreWithoutItsPointsIsATypedErrorNotAnOrigin) {
  AlignInputs in = PlaneCircleCircle();
  // A copy first: a block of the matrix assigned to itself would be read after its free.
  in.circle_c->evidence.points_mcs = in.circle_c->evidence.points_mcs.leftCols(3).eval();
  EXPECT_THROW(AssessAlign(in, kCalibration, features::PlausibilityLimits{}),
               features::FeatureError);
}

}  // namespace
}  // namespace mlp::jobs
