// The measure job in-process (issue 53): typed requests on the stored sample clouds, whose
// truth their generator wrote beside them (samples/clouds/README.md), through the same
// measure -> decide -> gate -> changes the service runs, without a daemon or a socket: fast
// enough to run under ASan and UBSan in every CI run.

#include "mlp/jobs/measure.h"

#include "mlp/base/check.h"
#include "mlp/features/feature.h"
#include "mlp/host/cloud_io.h"

#include <string>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

using geometry::Vec3;

// The sample clouds (text, x y z in mm a line), read by the host's own reader.
geometry::Points3 ReadXyz(const std::string& name) {
  return host::ReadCloud(test::SourceDir() + "/samples/clouds/" + name).points;
}

Evidence EvidenceOf(geometry::Points3 points_mcs) {
  Evidence e;
  e.points_mcs = std::move(points_mcs);
  e.probe_serial = "MLP-0001";
  return e;
}

const CalibrationFacts kCalibration{"cal-1", "MLP-0001", 2.0};

// bore_before_finish.xyz: d 59.94 (radius 29.97), axis Z through (40, 25), rings z -2..-12,
// a 3-lobe form of 4 um peak and 2 um noise; the part's nominal d 60 +0.03/-0.
MeasureRequest BoreRequest() {
  features::BoreNominal n;
  n.top_centre_mcs = Vec3(40, 25, 0);
  n.diameter_mm = 60.0;
  n.depth_mm = 14.0;
  MeasureRequest r;
  r.feature.nominal = {"bore", n};
  r.feature.traits = *TraitsOf("bore");
  r.feature.size = "ls";
  r.feature.spec = {60.0, 0.03, 0.0};
  return r;
}

ToolUpdateRequest RadiusWear(int offset) {
  ToolUpdateRequest u;
  u.offset = offset;
  u.reg = nc::ToolRegister::kRadiusWear;
  u.feedback.offset_number = offset;
  u.feedback.reg = u.reg;
  return u;
}

// The tool change as a controller that keeps its own values takes it (Fanuc-style: the
// service's ResolveToolChange for such a machine): an increment.
nc::ToolOffsetChange Increment(const MeasureOutcome& o) {
  return {o.feedback.offset_number, o.feedback.reg, 0.0, o.decision.offset_change_mm, true};
}

// The fit's own uncertainty on 1,440 points with 2 um noise is ~0.1 um; the 3-lobe form does
// not move a least-squares circle's size or centre.
constexpr double kSizeTolMm = 0.001;

TEST(MeasureJob, AnUndersizeBoreIsMeasuredAndItsRadiusWearMovedByHalfTheError) {
  MeasureRequest r = BoreRequest();
  r.update = RadiusWear(12);
  CheckUpdatesFit(r);
  const MeasureOutcome o = AssessMeasure(r, EvidenceOf(ReadXyz("bore_before_finish.xyz")),
                                         kCalibration, features::PlausibilityLimits{});
  EXPECT_NEAR(o.measured.size, 59.94, kSizeTolMm);
  EXPECT_NEAR(o.decision.error_mm, -0.06, kSizeTolMm);
  EXPECT_FALSE(o.in_tolerance);
  EXPECT_EQ(o.verdict, "out of tolerance");
  EXPECT_TRUE(o.refusal.empty()) << o.refusal.front();
  ASSERT_TRUE(o.decision.update);
  EXPECT_NEAR(o.decision.offset_change_mm, -0.03, kSizeTolMm / 2);  // +0.5 per unit of error
  const Reading* centre = Find(o.measured.readings, "centre_mm");
  ASSERT_NE(centre, nullptr);
  EXPECT_LT((std::get<Vec3>(centre->value) - Vec3(40, 25, 0)).head<2>().norm(), kSizeTolMm);
  ASSERT_NE(Find(o.measured.readings, "points"), nullptr);
  EXPECT_EQ(std::get<std::int64_t>(Find(o.measured.readings, "points")->value), 1440);

  const nc::NcResult out = MeasureChanges(o, 7, /*named_parameters=*/true, Increment(o));
  EXPECT_EQ(out.header, "mlprobe job 7: bore out of tolerance");
  ASSERT_EQ(out.tools.size(), 1u);
  EXPECT_EQ(out.tools[0].tool, 12);
  EXPECT_TRUE(out.tools[0].incremental);
  EXPECT_NEAR(out.tools[0].after_mm, -0.03, kSizeTolMm / 2);
  EXPECT_TRUE(out.work.empty());
  ASSERT_EQ(out.named.size(), 3u);
}

TEST(MeasureJob, AWorkOffsetFollowsTheBoreWhereItWasFound) {
  MeasureRequest r = BoreRequest();
  std::get<features::BoreNominal>(r.feature.nominal.shape).top_centre_mcs = Vec3(40.2, 24.9, 0);
  r.update_work = WorkUpdateRequest{3, {true, true, false}};
  CheckUpdatesFit(r);
  const MeasureOutcome o = AssessMeasure(r, EvidenceOf(ReadXyz("bore_before_finish.xyz")),
                                         kCalibration, features::PlausibilityLimits{});
  ASSERT_TRUE(o.work.has_value());
  EXPECT_EQ(o.work->index, 3);
  EXPECT_TRUE(o.work->incremental);
  EXPECT_NEAR(o.work->after_mm[0], -0.2, kSizeTolMm);  // found at 40, nominal 40.2
  EXPECT_NEAR(o.work->after_mm[1], 0.1, kSizeTolMm);
  EXPECT_EQ(o.work->after_mm[2], 0.0);  // Z not asked for
  const nc::NcResult out = MeasureChanges(o, 8, false, std::nullopt);
  ASSERT_EQ(out.work.size(), 1u);
  EXPECT_TRUE(out.named.empty());  // not LinuxCNC: no #<_mlp_...> parameters
  EXPECT_TRUE(out.tools.empty());
}

// top_face.xyz: 80 x 60 mm at z = 0, tilted 0.01 deg about X (the fit takes the tilt out), a
// 3 um crown along X (its mean 2 um), 1 um noise.
MeasureRequest FaceRequest() {
  features::PlaneNominal n;
  n.point_mcs = Vec3(40, 30, 0);
  MeasureRequest r;
  r.feature.nominal = {"face", n};
  r.feature.traits = *TraitsOf("face");
  r.feature.spec = {0.0, 0.02, 0.02};
  return r;
}

TEST(MeasureJob, AFaceWithinItsHeightButOverItsFlatnessToleranceIsOutOfTolerance) {
  MeasureRequest r = FaceRequest();
  r.feature.flatness_tol_mm = 0.002;  // the crown alone is 3 um
  const MeasureOutcome o = AssessMeasure(r, EvidenceOf(ReadXyz("top_face.xyz")), kCalibration,
                                         features::PlausibilityLimits{});
  EXPECT_NEAR(o.measured.size, 0.002, 0.001);  // the crown's mean over the face
  const auto flatness = std::get<double>(Find(o.measured.readings, "flatness_mm")->value);
  EXPECT_GT(flatness, 0.003);  // the crown, plus the noise's extremes
  EXPECT_LT(flatness, 0.003 + 8 * 0.001);
  EXPECT_FALSE(o.in_tolerance);
  EXPECT_EQ(o.verdict, "out of tolerance");
  ASSERT_EQ(o.measured.problems.size(), 1u);
  EXPECT_EQ(o.reason.rfind("flatness", 0), 0u) << o.reason;  // the exceeded tolerance first
  EXPECT_NE(MeasureReportSvg(o, "face", "2026-12-07T00:00:00Z").find("flatness"),
            std::string::npos);
}

TEST(MeasureJob, AnUpdateTheFeatureCannotMoveIsRefusedAsInput) {
  MeasureRequest face = FaceRequest();
  face.update = RadiusWear(5);  // a face moves a tool's length, not its radius
  EXPECT_THROW(CheckUpdatesFit(face), RequestError);
  MeasureRequest bore = BoreRequest();
  bore.update = RadiusWear(5);
  bore.update->reg = nc::ToolRegister::kLengthWear;
  EXPECT_THROW(CheckUpdatesFit(bore), RequestError);
}

TEST(MeasureJob, ThePlausibilityGateRefusesAnotherProbesCalibrationAndNothingIsWritten) {
  MeasureRequest r = BoreRequest();
  r.update = RadiusWear(12);
  const CalibrationFacts other{"cal-2", "MLP-0002", 2.0};
  const MeasureOutcome o = AssessMeasure(r, EvidenceOf(ReadXyz("bore_before_finish.xyz")), other,
                                         features::PlausibilityLimits{});
  ASSERT_FALSE(o.refusal.empty());
  EXPECT_NE(o.refusal.front().find("MLP-0002"), std::string::npos) << o.refusal.front();
  // Asking for the changes of a refused outcome is a programming error, not a write.
  EXPECT_THROW(MeasureChanges(o, 9, true, Increment(o)), base::CheckFailure);
}

TEST(MeasureJob, AQuarterOfTheBoreIsRefusedByTheGateNotMeasuredAsAWholeOne) {
  geometry::Points3 all = ReadXyz("bore_before_finish.xyz");
  std::vector<Eigen::Index> quarter;
  for (Eigen::Index i = 0; i < all.cols(); ++i)
    if (all(0, i) > 40 && all(1, i) > 25) quarter.push_back(i);
  geometry::Points3 arc(3, static_cast<Eigen::Index>(quarter.size()));
  for (size_t k = 0; k < quarter.size(); ++k)
    arc.col(static_cast<Eigen::Index>(k)) = all.col(quarter[k]);
  MeasureRequest r = BoreRequest();
  r.update = RadiusWear(12);
  const MeasureOutcome o =
      AssessMeasure(r, EvidenceOf(arc), kCalibration, features::PlausibilityLimits{});
  ASSERT_FALSE(o.refusal.empty());
  bool arc_named = false;
  for (const std::string& p : o.refusal)
    arc_named |= p.find("deg of the circle") != std::string::npos;
  EXPECT_TRUE(arc_named) << ::testing::PrintToString(o.refusal);
}

TEST(MeasureJob, TooFewPointsForTheFeatureAreATypedErrorNotANumber) {
  geometry::Points3 few = ReadXyz("bore_before_finish.xyz").leftCols(4);
  EXPECT_THROW(
      AssessMeasure(BoreRequest(), EvidenceOf(few), kCalibration, features::PlausibilityLimits{}),
      features::FeatureError);
}

}  // namespace
}  // namespace mlp::jobs
