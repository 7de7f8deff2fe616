// Sphere hand-eye calibration against ground truth: synthetic caps of the sphere with noise and
// outliers, pose sets that do and do not determine M, and single laser profiles.

#include "mlp/calib/hand_eye.h"

#include <random>

#include "hand_eye_fixture.h"
#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

using testing::PoseSet;

constexpr double kTranslationTolMm = 0.002;  // issue 5: M translation within 2 um
constexpr double kRotationTolArcsec = 5.0;   // and rotation within 5 arcsec
constexpr double kCentreTolMm = 0.002;       // sphere centre within 2 um when observable
constexpr double kNoiseMm = 0.002;           // per point, along the surface normal

TEST(HandEye, FiveAxisPosesRecoverMountingAndCentre) {
  const testing::Truth truth = testing::DefaultTruth();
  const auto poses = testing::MakePoses(truth, PoseSet::kFiveAxis, 12);
  const auto captures = testing::SyntheticCaps(truth, poses, kNoiseMm, 0.02, 2000, 7);
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const HandEyeResult r = SolveSphereHandEye(captures, o);
  const testing::Errors e = testing::ErrorsOf(truth, r, "five-axis caps");
  EXPECT_LT(e.translation_mm, kTranslationTolMm);
  EXPECT_LT(e.rotation_arcsec, kRotationTolArcsec);
  EXPECT_LT(e.centre_mm, kCentreTolMm);
  EXPECT_NEAR(r.point_rms_mm, kNoiseMm, 0.2 * kNoiseMm);
  EXPECT_GT(r.points_rejected, 12 * 2000 * 0.015);  // the 2 % outliers went
  // The covariance is honest: each translation error is within 4 of its standard deviations.
  for (int k = 0; k < 3; ++k) {
    const double sd = std::sqrt(r.covariance(3 + k, 3 + k));
    EXPECT_GT(sd, 0.0);
    EXPECT_LT(
        std::abs(r.flange_from_probe.translation()(k) - truth.flange_from_probe.translation()(k)),
        4 * sd + 1e-5);
  }
  EXPECT_TRUE(r.warnings.empty()) << r.warnings.front();
}

TEST(HandEye, TranslationsOnlyAreRefusedWithWhatWouldFixIt) {
  const testing::Truth truth = testing::DefaultTruth();
  const auto captures = testing::SyntheticCaps(
      truth, testing::MakePoses(truth, PoseSet::kTranslationsOnly, 8), kNoiseMm, 0.0, 800, 3);
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const auto e = testing::Refusal(captures, o);
  ASSERT_TRUE(e.has_value());
  EXPECT_EQ(e->kind(), HandEyeError::Kind::kUnderDetermined);
  const std::string what = e->what();
  EXPECT_NE(what.find("M's offset along flange X"), std::string::npos) << what;
  EXPECT_NE(what.find("the sphere centre's X"), std::string::npos) << what;
  ASSERT_GE(e->proposals().size(), 2u);
  EXPECT_NE(e->proposals()[0].find("M19"), std::string::npos);
}

TEST(HandEye, SpindleOrientationsLeaveZOpenUntilTheSphereZIsGiven) {
  const testing::Truth truth = testing::DefaultTruth();
  const auto captures = testing::SyntheticCaps(
      truth, testing::MakePoses(truth, PoseSet::kThreeAxisWithM19, 12), kNoiseMm, 0.02, 2000, 5);
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const auto refusal = testing::Refusal(captures, o);
  ASSERT_TRUE(refusal.has_value());
  const std::string what = refusal->what();
  EXPECT_NE(what.find("M's offset along flange Z"), std::string::npos) << what;
  EXPECT_NE(what.find("the sphere centre's Z"), std::string::npos) << what;
  EXPECT_EQ(what.find("flange X"), std::string::npos) << what;  // X and Y are determined
  ASSERT_FALSE(refusal->proposals().empty());
  EXPECT_NE(refusal->proposals()[0].find("centre's Z"), std::string::npos);

  o.known_centre_mcs[2] = truth.centre_mcs.z();
  const HandEyeResult r = SolveSphereHandEye(captures, o);
  const testing::Errors e = testing::ErrorsOf(truth, r, "M19 + known Z");
  EXPECT_LT(e.translation_mm, kTranslationTolMm);
  EXPECT_LT(e.rotation_arcsec, kRotationTolArcsec);
  EXPECT_LT(e.centre_mm, kCentreTolMm);
  EXPECT_EQ(r.covariance(8, 8), 0.0);  // the given coordinate is not estimated
}

TEST(HandEye, SingleProfilesWithBackgroundFindTheirSides) {
  const testing::Truth truth = testing::DefaultTruth();
  const auto poses = testing::MakePoses(truth, PoseSet::kFiveAxis, 12);
  const auto captures = testing::SyntheticProfiles(truth, poses, kNoiseMm, 400, 9);
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const HandEyeResult r = SolveSphereHandEye(captures, o);
  const testing::Errors e = testing::ErrorsOf(truth, r, "single profiles");
  // One profile per pose holds far less information than a cap: 5x the cap tolerances.
  EXPECT_LT(e.translation_mm, 5 * kTranslationTolMm);
  EXPECT_LT(e.rotation_arcsec, 5 * kRotationTolArcsec);
  EXPECT_LT(e.centre_mm, 5 * kCentreTolMm);
}

TEST(HandEye, BadInputIsATypedError) {
  const testing::Truth truth = testing::DefaultTruth();
  auto captures = testing::SyntheticCaps(truth, testing::MakePoses(truth, PoseSet::kFiveAxis, 6),
                                         kNoiseMm, 0.0, 200, 1);
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const auto kind = [&](std::vector<SphereCapture> c, HandEyeOptions opt) {
    try {
      SolveSphereHandEye(c, opt);
    } catch (const HandEyeError& e) {
      return e.kind();
    }
    ADD_FAILURE() << "accepted";
    return HandEyeError::Kind::kUnderDetermined;
  };
  EXPECT_EQ(kind({captures.begin(), captures.begin() + 2}, o), HandEyeError::Kind::kBadInput);
  HandEyeOptions bad = o;
  bad.sphere_radius_mm = -1;
  EXPECT_EQ(kind(captures, bad), HandEyeError::Kind::kBadInput);
  auto scaled = captures;
  scaled[0].mcs_from_flange.linear() *= 1.01;
  EXPECT_EQ(kind(scaled, o), HandEyeError::Kind::kBadInput);
  auto nan = captures;
  nan[1].mcs_from_flange.translation()(0) = NAN;
  EXPECT_EQ(kind(nan, o), HandEyeError::Kind::kBadInput);
  // NaN points are dropped (a scanner's "no return"), not propagated.
  auto holes = captures;
  holes[2].points_in_probe.col(0).setConstant(NAN);
  EXPECT_NO_THROW(SolveSphereHandEye(holes, o));
}

}  // namespace
}  // namespace mlp::calib
