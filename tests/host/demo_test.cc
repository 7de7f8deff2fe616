// The whole chain in one test, as `mlp demo` runs it: virtual probe frames -> firmware ->
// authenticated link -> mlp-hostd -> decisions -> tool table and result subroutine, against the
// demo scene's ground truth (issue 6): alignment origin within 5 um and rotation within 10
// arcsec, bore diameter within 2 um, the written wear offset equal to the expected one.

#include "mlp/nc/tool_table.h"

#include <cmath>
#include <filesystem>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// The demo runs the calibrated chain (issue 16): the virtual probe renders as built, the
// firmware and host know it through cal-as-built-1. Issue 16's done-means for that chain:
// alignment origin <= 5 um and <= 10 arcsec, bore diameter <= 2 um, hand-eye <= 5 um. Issue 5's
// 2 um / 5 arcsec for the hand-eye hold where the firmware's model is the truth
// (tests/calib/virtual_hand_eye_test.cc, which keeps them); through a calibration the true M is
// only defined in the calibrated probe frame (sim::TrueFromModelFrame), and its rotation is held
// to the alignment's 10 arcsec (issue 16 names none for the hand-eye).
constexpr double kOriginTolUm = 5.0;
constexpr double kRotationTolArcsec = 10.0;
constexpr double kDiameterTolMm = 0.002;
constexpr double kHandEyeTolUm = 5.0, kHandEyeTolArcsec = 10.0;  // issue 16
constexpr double kFinishedDiameterMm = 60.0;                     // the demo's nominal
constexpr double kRadiusBeforeMm = 4.999;                        // T12 D9.998 in the sample table
constexpr double kSameNumber = 1e-12;    // the reply's figures against each other
constexpr double kTableDigitsMm = 1e-6;  // the tool table keeps 6 digits

TEST(Demo, TheWholeChainMeetsTheTruth) {
  const fs::path dir = fs::temp_directory_path() / "mlp_demo_test";
  fs::remove_all(dir);
  const auto run =
      test::RunProcess(mlp::test::Program("mlp") + " demo --json --port 17436 --dir " +
                       dir.string() + " --samples " + mlp::test::SourceDir() + "/samples");
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json s = json::parse(run.out);
  std::printf("%s\n", s.dump().c_str());
  EXPECT_LT(s.at("calibration").at("translation_error_um").get<double>(), kHandEyeTolUm);
  EXPECT_LT(s.at("calibration").at("rotation_error_arcsec").get<double>(), kHandEyeTolArcsec);
  for (const auto& e : s.at("alignment").at("origin_error_um"))
    EXPECT_LT(std::abs(e.get<double>()), kOriginTolUm);
  EXPECT_LT(std::abs(s.at("alignment").at("rotation_error_arcsec").get<double>()),
            kRotationTolArcsec);
  const json& b = s.at("bore");
  EXPECT_NEAR(b.at("diameter_mm").get<double>(), b.at("true_diameter_mm").get<double>(),
              kDiameterTolMm);
  // The wear offset written: half the diameter error, 100 % feedback, onto T12's radius.
  const double change = (b.at("diameter_mm").get<double>() - kFinishedDiameterMm) / 2;
  EXPECT_NEAR(b.at("change_mm").get<double>(), change, kSameNumber);
  EXPECT_EQ(b.at("radius_before_mm").get<double>(), kRadiusBeforeMm);
  EXPECT_NEAR(b.at("radius_after_mm").get<double>(), kRadiusBeforeMm + change, kSameNumber);
  const auto t12 = nc::LoadToolTable(s.at("tool_table").get<std::string>()).Find(12);
  ASSERT_TRUE(t12);
  EXPECT_NEAR(t12->Get('D'), 2 * (kRadiusBeforeMm + change), kTableDigitsMm);
  EXPECT_TRUE(fs::exists(b.at("report").get<std::string>()));
}

}  // namespace
}  // namespace mlp
