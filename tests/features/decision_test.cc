// Size -> offset decisions in the shop's vocabulary, and the plausibility gate before writes.

#include "mlp/features/decision.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

namespace mlp::features {
namespace {

constexpr double kExactMm = 1e-12;

// The seed 004 case: a bore to be finished to 60 mm +0.03/-0, measured before the finishing pass.
SizeSpec Bore60() { return {60.0, 0.030, 0.0}; }
Feedback RadiusWear(int tool) {
  Feedback f;
  f.offset_number = tool;
  f.reg = nc::ToolRegister::kRadiusWear;
  f.change_per_error = 0.5;
  f.null_band_mm = 0.002;
  f.upper_limit_mm = 0.5;
  return f;
}

TEST(SizeDecision, ABoreTooSmallMovesTheRadiusWear) {
  const SizeDecision d = DecideSize(59.994, Bore60(), RadiusWear(12));
  EXPECT_EQ(d.verdict, Verdict::kOutOfTolerance);
  EXPECT_TRUE(d.update);
  EXPECT_NEAR(d.error_mm, -0.006, kExactMm);
  EXPECT_NEAR(d.offset_change_mm, -0.003, kExactMm);  // half the diameter error
  EXPECT_NE(d.reason.find("radius wear 12 changes by -3.0 um"), std::string::npos) << d.reason;
}

TEST(SizeDecision, FeedbackExperienceNullBandAndUpperLimit) {
  Feedback f = RadiusWear(12);
  f.percent = 50;
  EXPECT_NEAR(DecideSize(59.994, Bore60(), f).offset_change_mm, -0.0015, kExactMm);
  f.experience_mm = 0.004;  // this machine measures bores 4 um small: 59.994 is really 59.998
  SizeDecision d = DecideSize(59.994, Bore60(), f);
  EXPECT_NEAR(d.measured_mm, 59.998, kExactMm);
  EXPECT_NEAR(d.offset_change_mm, -0.0005, kExactMm);
  d = DecideSize(60.0015, Bore60(), RadiusWear(12));  // in tolerance, inside the null band
  EXPECT_EQ(d.verdict, Verdict::kInTolerance);
  EXPECT_FALSE(d.update);
  EXPECT_EQ(d.offset_change_mm, 0.0);
  EXPECT_NE(d.reason.find("null band"), std::string::npos);
  d = DecideSize(60.01, Bore60(), RadiusWear(12));  // in tolerance, still corrected
  EXPECT_EQ(d.verdict, Verdict::kInTolerance);
  EXPECT_NEAR(d.offset_change_mm, 0.005, kExactMm);
  d = DecideSize(59.2, Bore60(), RadiusWear(12));  // 0.8 mm: a wrong tool, a broken insert
  EXPECT_EQ(d.verdict, Verdict::kUpperLimitExceeded);
  EXPECT_FALSE(d.update);
  EXPECT_NE(d.reason.find("upper tolerance limit"), std::string::npos);
  Feedback report = RadiusWear(0);
  d = DecideSize(59.994, Bore60(), report);
  EXPECT_EQ(d.verdict, Verdict::kOutOfTolerance);
  EXPECT_FALSE(d.update);
}

TEST(SizeDecision, LengthFromAFaceAndABoss) {
  Feedback f = RadiusWear(3);
  f.reg = nc::ToolRegister::kLengthWear;
  f.change_per_error = -1.0;
  // A face 5 um higher than its nominal depth: the tool is 5 um shorter than its offset says.
  EXPECT_NEAR(DecideSize(-9.995, {-10.0, 0.01, 0.01}, f).offset_change_mm, -0.005, kExactMm);
  f.reg = nc::ToolRegister::kRadiusWear;
  f.change_per_error = -0.5;  // a boss 8 um large: the radius offset grows 4 um
  EXPECT_NEAR(DecideSize(40.008, {40.0, 0.0, 0.02}, f).offset_change_mm, -0.004, kExactMm);
}

TEST(SizeDecision, MeaninglessSettingsAreRefused) {
  Feedback f = RadiusWear(1);
  f.percent = 0;
  EXPECT_THROW(DecideSize(60, Bore60(), f), DecisionError);
  f.percent = 120;
  EXPECT_THROW(DecideSize(60, Bore60(), f), DecisionError);
  EXPECT_THROW(DecideSize(std::nan(""), Bore60(), RadiusWear(1)), DecisionError);
  EXPECT_THROW(DecideSize(60, {60, -0.01, 0}, RadiusWear(1)), DecisionError);
  f = RadiusWear(1);
  f.null_band_mm = 1.0;  // above the upper limit
  EXPECT_THROW(DecideSize(60, Bore60(), f), DecisionError);
}

TEST(Plausibility, EveryReasonIsListed) {
  FitEvidence e;
  e.points = 5000;
  e.arc_span_deg = 350;
  e.rms_mm = 0.002;
  e.calibration_probe = e.job_probe = "MLP-1";
  e.calibration_age_h = 2;
  e.offset_changes_mm = {-0.003};
  const PlausibilityLimits l;
  EXPECT_TRUE(PlausibilityProblems(e, l).empty());
  e.points = 50;
  e.arc_span_deg = 90;
  e.rms_mm = 0.05;
  e.calibration_age_h = 1000;
  e.offset_changes_mm = {0.003, -0.5};
  const auto p = PlausibilityProblems(e, l);
  ASSERT_EQ(p.size(), 5u);
  EXPECT_NE(p[0].find("50 points"), std::string::npos);
  EXPECT_NE(p[1].find("90 deg"), std::string::npos);
  EXPECT_NE(p[2].find("RMS 50.0 um"), std::string::npos);
  EXPECT_NE(p[3].find("1000.0 h old"), std::string::npos);
  EXPECT_NE(p[4].find("-500.0 um"), std::string::npos);
  e.offset_changes_mm.clear();
  e.points = 5000;
  e.arc_span_deg = 350;
  e.rms_mm = 0.002;
  e.calibration_age_h = 2;
  e.work_shift_mm = 7.5;
  e.tilt_deg = 0.8;
  const auto align = PlausibilityProblems(e, l);
  ASSERT_EQ(align.size(), 2u);
  EXPECT_NE(align[0].find("7.500 mm from where it was expected"), std::string::npos) << align[0];
  EXPECT_NE(align[1].find("tilted 0.800 deg"), std::string::npos) << align[1];
  e.work_shift_mm.reset();
  e.tilt_deg.reset();
  e.converged = false;  // a fit that stopped at its iteration limit: an estimate, never written
  const auto estimate = PlausibilityProblems(e, l);
  ASSERT_EQ(estimate.size(), 1u);
  EXPECT_NE(estimate[0].find("before converging"), std::string::npos) << estimate[0];
  e = {};
  e.points = 5000;
  e.job_probe = "MLP-2";
  EXPECT_NE(PlausibilityProblems(e, l).front().find("no calibration for probe MLP-2"),
            std::string::npos);
  e.calibration_probe = "MLP-1";
  EXPECT_NE(PlausibilityProblems(e, l).front().find("is for probe MLP-1"), std::string::npos);
  e.calibration_probe = "MLP-2";
  e.rms_mm = std::nan("");  // a NaN never passes
  EXPECT_EQ(PlausibilityProblems(e, l).size(), 1u);
}

}  // namespace
}  // namespace mlp::features
