// The picture a person reads at the machine: a roundness plot with the numbers and the verdict.

#include "mlp/features/report.h"

#include <cmath>
#include <fstream>
#include <regex>

#include <gtest/gtest.h>

namespace mlp::features {
namespace {

BoreReport Report() {
  BoreReport r;
  r.title = "job 42 - bore - vmc-1 <B1>";
  r.nominal_mm = 60.0, r.upper_tol_mm = 0.03, r.lower_tol_mm = 0.0;
  r.bore.diameter_mm = 59.994, r.bore.functional_diameter_mm = 59.990;
  r.bore.points = 50000, r.bore.arc_span_deg = 290, r.bore.rms_mm = 0.0018;
  r.bore.deviation_by_degree_mm.assign(360, std::nan(""));
  for (int d = 0; d < 290; ++d)  // a lobed bore: +-4 um, three lobes
    r.bore.deviation_by_degree_mm[static_cast<size_t>(d)] = 0.004 * std::cos(3 * d * M_PI / 180);
  r.size_mm = 59.994, r.error_mm = -0.006;
  r.verdict = "out of tolerance";
  r.decision = "radius wear 12 changes by -3.0 um";
  r.time_utc = "2026-11-22T00:40:00.000Z";
  return r;
}

TEST(Report, BoreRoundnessPlotHasTheNumbersAndTheVerdict) {
  const std::string svg = BoreReportSvg(Report());
  std::ofstream(::testing::TempDir() + "/bore_report.svg") << svg;  // to look at
  EXPECT_EQ(svg.rfind("<svg ", 0), 0u);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
  // One dot per degree with points, none where the probe saw nothing.
  const std::regex dot("r='2.2'");
  EXPECT_EQ(
      std::distance(std::sregex_iterator(svg.begin(), svg.end(), dot), std::sregex_iterator()),
      290);
  EXPECT_NE(svg.find(">out of tolerance<"), std::string::npos);
  EXPECT_NE(svg.find("fill='#b35900'>out of tolerance"), std::string::npos);  // amber
  EXPECT_NE(svg.find("size 59.9940 mm (nominal 60.000 +0.030/-0.000)"), std::string::npos);
  EXPECT_NE(svg.find("error -6.0 um"), std::string::npos);
  EXPECT_NE(svg.find("&lt;B1&gt;"), std::string::npos);  // text is escaped
  // The most outward lobe is red, the most inward blue.
  EXPECT_NE(svg.find("fill='#ff0000'"), std::string::npos);
  EXPECT_NE(svg.find("fill='#0000ff'"), std::string::npos);
}

}  // namespace
}  // namespace mlp::features
