// Process capability (ISO 22514-2, AIAG individuals and moving range) against values whose
// statistics are known by construction: alternating values (every moving range the same), a
// steady drift (small within-sigma, large overall: Cpk high, Ppk low), and a seeded normal
// sample whose sigma the moving range must find; an outlier beyond the control limits; and the
// values that give no capability refused.

#include "mlp/features/spc.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

namespace mlp::features {
namespace {

constexpr double kExact = 1e-12;
constexpr double kD2 = 1.128;  // d2 for ranges of two values
// A normal sample of 20000: the moving-range estimate's relative standard error is about
// 0.83 / sqrt(n) = 0.6 %; 3 % is five of them.
constexpr double kSigmaRelTol = 0.03;

TEST(Spc, AlternatingValuesHaveKnownSigmas) {
  // 40 values 10.000 +- 0.002 in turn: every moving range 0.004.
  std::vector<double> v;
  for (int i = 0; i < 40; ++i) v.push_back(10.0 + (i % 2 ? 0.002 : -0.002));
  const CapabilityStudy s = StudyCapability(v, {9.99, 10.02});
  EXPECT_NEAR(s.mean, 10.0, kExact);
  EXPECT_NEAR(s.sigma_within, 0.004 / kD2, kExact);
  EXPECT_NEAR(s.sigma_overall, 0.002 * std::sqrt(40.0 / 39.0), kExact);
  EXPECT_NEAR(s.cp, 0.03 / (6 * 0.004 / kD2), 1e-9);
  EXPECT_NEAR(s.cpk, 0.01 / (3 * 0.004 / kD2), 1e-9);  // nearer the lower limit
  EXPECT_NEAR(s.ppk, 0.01 / (3 * 0.002 * std::sqrt(40.0 / 39.0)), 1e-9);
  EXPECT_NEAR(s.ucl - s.lcl, 6 * 0.004 / kD2, 1e-12);
  EXPECT_EQ(s.out_of_spec, 0);
  EXPECT_TRUE(s.out_of_control.empty());
  EXPECT_FALSE(s.few_values);
}

// A tool wearing 1 um a part: parts differ little from their neighbours (within-sigma 1 um /
// 1.128) but spread over 30 um overall: Cpk flatters, Ppk tells.
TEST(Spc, ADriftShowsInPpkNotInCpk) {
  std::vector<double> v;
  for (int i = 0; i < 30; ++i) v.push_back(40.0 + 0.001 * i);
  const CapabilityStudy s = StudyCapability(v, {39.98, 40.05});
  EXPECT_NEAR(s.sigma_within, 0.001 / kD2, kExact);
  EXPECT_NEAR(s.sigma_overall, 0.001 * std::sqrt(30.0 * 31.0 / 12.0), 1e-12);  // (n(n+1)/12)^.5
  EXPECT_GT(s.cpk, 5.0);
  EXPECT_LT(s.ppk, 1.5);
  EXPECT_FALSE(s.out_of_control.empty());  // the ends of the drift leave the chart's limits
}

TEST(Spc, ANormalSamplesSigmaAndAnOutlierBeyondTheControlLimits) {
  std::mt19937 rng(91);
  std::normal_distribution<double> n(25.0, 0.002);
  std::vector<double> v(20000);
  for (double& x : v) x = n(rng);
  const CapabilityStudy s = StudyCapability(v, {24.99, 25.01});
  EXPECT_NEAR(s.sigma_within / 0.002, 1.0, kSigmaRelTol);
  EXPECT_NEAR(s.sigma_overall / 0.002, 1.0, kSigmaRelTol);
  EXPECT_NEAR(s.cp, 0.02 / 0.012, 0.02 / 0.012 * kSigmaRelTol);
  // 200 parts with one 10 sigma off: flagged beyond the control limits, and out of spec.
  std::vector<double> few(v.begin(), v.begin() + 200);
  few[50] = 25.02;
  const CapabilityStudy f = StudyCapability(few, {24.99, 25.01});
  ASSERT_FALSE(f.out_of_control.empty());
  EXPECT_NE(std::find(f.out_of_control.begin(), f.out_of_control.end(), 50),
            f.out_of_control.end());
  EXPECT_EQ(f.out_of_spec, 1);
}

TEST(Spc, ValuesThatGiveNoCapabilityAreRefused) {
  EXPECT_THROW(StudyCapability({1.0}, {0, 2}), SpcError);
  EXPECT_THROW(StudyCapability({1.0, 1.0, 1.0}, {0, 2}), SpcError);  // no spread
  EXPECT_THROW(StudyCapability({1.0, std::numeric_limits<double>::quiet_NaN()}, {0, 2}), SpcError);
  EXPECT_THROW(StudyCapability({1.0, 1.1}, {2, 0}), SpcError);
  EXPECT_THROW(StudyCapability({1.0, 1.1}, {0, std::numeric_limits<double>::infinity()}), SpcError);
  const CapabilityStudy s = StudyCapability({1.0, 1.1, 1.05}, {0, 2});
  EXPECT_TRUE(s.few_values);
}

TEST(Spc, TheRunChartShowsEveryValueAndTheLimits) {
  const std::vector<double> v = {10.0, 10.004, 9.998, 10.021, 10.001};
  const CapabilityStudy s = StudyCapability(v, {9.99, 10.02});
  const std::string svg = RunChartSvg(v, {9.99, 10.02}, s, "bore <B1> & co", "mm");
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  size_t circles = 0, red = 0;
  for (size_t at = svg.find("<circle"); at != std::string::npos; at = svg.find("<circle", at + 1))
    ++circles;
  const std::string red_point = "r=\"3\" fill=\"red\"";  // a value's circle, not a label
  for (size_t at = svg.find(red_point); at != std::string::npos; at = svg.find(red_point, at + 1))
    ++red;
  EXPECT_EQ(circles, v.size());
  EXPECT_EQ(red, 1u);  // 10.021 is over the upper limit
  for (const char* name : {">USL ", ">LSL ", ">UCL ", ">LCL ", ">mean "})
    EXPECT_NE(svg.find(name), std::string::npos) << name;
  EXPECT_NE(svg.find("bore &lt;B1&gt; &amp; co"), std::string::npos);  // escaped
  EXPECT_EQ(svg.find("<B1>"), std::string::npos);
}

}  // namespace
}  // namespace mlp::features
