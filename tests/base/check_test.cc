// base/check and base/units: a failed precondition names its place and its values; units
// convert both ways exactly enough for metrology.

#include "mlp/base/check.h"

#include "mlp/base/units.h"

#include <cmath>
#include <string>

#include <gtest/gtest.h>

namespace mlp::base {
namespace {

std::string MessageOf(void (*f)()) {
  try {
    f();
  } catch (const CheckFailure& e) {
    return e.what();
  }
  return "";
}

TEST(Check, APassingCheckDoesNothing) {
  EXPECT_NO_THROW(MLP_CHECK(1 + 1 == 2));
  EXPECT_NO_THROW(MLP_CHECK_LE(2, 2));
  EXPECT_NO_THROW(MLP_CHECK_MSG(true, "never shown"));
}

TEST(Check, AFailedComparisonNamesFileLineExpressionAndBothValues) {
  const std::string m = MessageOf([] {
    const int points = 2, needed = 3;
    MLP_CHECK_GE(points, needed);
  });
  EXPECT_NE(m.find("check_test.cc:"), std::string::npos) << m;
  EXPECT_NE(m.find("points >= needed"), std::string::npos) << m;
  EXPECT_NE(m.find("points = 2, needed = 3"), std::string::npos) << m;
}

TEST(Check, AFailedCheckWithAMessageCarriesIt) {
  const std::string m = MessageOf([] { MLP_CHECK_MSG(std::isfinite(NAN), "the radius is NaN"); });
  EXPECT_NE(m.find("std::isfinite(NAN)"), std::string::npos) << m;
  EXPECT_NE(m.find("the radius is NaN"), std::string::npos) << m;
}

TEST(Check, EvaluatesEachOperandOnce) {
  int calls = 0;
  const auto next = [&calls] { return ++calls; };
  MLP_CHECK_LT(next(), 10);
  EXPECT_EQ(calls, 1);
}

TEST(Units, ConvertBothWays) {
  constexpr double kTolerance = 1e-15;  // relative, a few ulps
  EXPECT_NEAR(DegFromRad(kPi), 180.0, 180.0 * kTolerance);
  EXPECT_NEAR(RadFromDeg(90.0), kPi / 2, kTolerance);
  EXPECT_NEAR(ArcsecFromRad(RadFromDeg(1.0)), 3600.0, 3600.0 * kTolerance);
  EXPECT_NEAR(UmFromMm(0.0123), 12.3, 12.3 * kTolerance);
}

}  // namespace
}  // namespace mlp::base
