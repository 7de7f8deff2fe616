// Sub-pixel crossings of a rendered step edge: a straight edge at a known sub-pixel place,
// blurred by a Gaussian and noised, is found where it is.

#include "mlp/geometry/contour.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kDark = 25, kBright = 210, kLevel = (kDark + kBright) / 2;
constexpr double kMeanTolPx = 0.01;        // 200 rows: the mean edge to 1/100 px
constexpr double kCircleBiasTolPx = 0.02;  // the mean distance of a circle's crossings

// A vertical edge at u = edge (dark left of it) with a Gaussian blur of sigma px: the grey of a
// pixel is the blurred step's value at its centre.
std::vector<std::uint8_t> Step(
    int w, int h, double edge, double sigma, double noise, bool vertical) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, noise);
  std::vector<std::uint8_t> px(static_cast<size_t>(w * h));
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const double x = (vertical ? u : v) - edge;
      const double light = 0.5 * (1 + std::erf(x / (sigma * std::sqrt(2.0))));
      px[static_cast<size_t>(v * w + u)] =
          static_cast<std::uint8_t>(std::lround(kDark + (kBright - kDark) * light + n(rng)));
    }
  return px;
}

TEST(Contour, RowCrossingsFindAVerticalEdgeToAFewHundredthsOfAPixel) {
  const auto px = Step(64, 200, 30.37, 0.8, 2.0, true);
  const Points2 c = RowCrossings({px.data(), 64, 200}, kLevel);
  ASSERT_EQ(c.cols(), 200);
  EXPECT_NEAR(c.row(0).mean(), 30.37, kMeanTolPx);
  // Each row alone: the noise through the centroid of the steps, under 0.1 px RMS.
  EXPECT_LT(std::sqrt((c.row(0).array() - 30.37).square().mean()), 0.1);
  EXPECT_EQ(c(1, 17), 17);
}

TEST(Contour, ColumnCrossingsFindAHorizontalEdge) {
  const auto px = Step(150, 80, 41.62, 0.8, 2.0, false);
  const Points2 c = ColumnCrossings({px.data(), 150, 80}, kLevel);
  ASSERT_EQ(c.cols(), 150);
  EXPECT_NEAR(c.row(1).mean(), 41.62, kMeanTolPx);
}

// A window into the image scans only its own columns and rows (two shadows on one row: each
// found in its window), in the window's coordinates.
TEST(Contour, AWindowScansOnlyItsPart) {
  const auto px = Step(64, 200, 30.37, 0.8, 2.0, true);
  const GreyView whole{px.data(), 64, 200};
  const GreyView w = whole.Window(20, 50, 30, 400);  // clipped at the image's bottom
  EXPECT_EQ(w.height, 150);
  const Points2 c = RowCrossings(w, kLevel);
  ASSERT_EQ(c.cols(), 150);
  EXPECT_NEAR(c.row(0).mean() + 20, 30.37, kMeanTolPx);
  EXPECT_EQ(c(1, 0), 0);  // the window's first row: the image's row 50
  EXPECT_EQ(w.At(0, 0), whole.At(20, 50));
  EXPECT_EQ(RowCrossings(whole.Window(40, 0, 24, 200), kLevel).cols(), 0);  // light only
}

// A shadow's edge with another shadow 3 px on (a coolant drop just off a tool's flank): the
// falling steps of the second are inside the centroid's window; the crossing stays on the
// first edge (it ran 85 px off before).
TEST(Contour, AnEdgeWithAnotherJustBehindItStaysOnItsOwn) {
  const std::vector<std::uint8_t> row = {25, 25, 25, 25, 25, 44, 97, 155, 171, 77, 30, 25, 25, 25};
  const Points2 c = RowCrossings({row.data(), static_cast<int>(row.size()), 1}, kLevel);
  ASSERT_EQ(c.cols(), 1);
  EXPECT_GT(c(0, 0), 5.0);
  EXPECT_LT(c(0, 0), 7.0);
}

// A dark disc (radius 40.3 px, blurred): every row's and column's crossings, both sides,
// lie on its circle; the mean distance is unbiased to 0.02 px.
TEST(Contour, AllCrossingsTraceAShapeOfAnyKind) {
  constexpr int kSize = 120;
  const double cx = 60.4, cy = 58.7, r = 40.3, sigma = 0.8;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 2.0);
  std::vector<std::uint8_t> px(kSize * kSize);
  for (int v = 0; v < kSize; ++v)
    for (int u = 0; u < kSize; ++u) {
      const double d = std::hypot(u - cx, v - cy) - r;  // + outside: light
      const double light = 0.5 * (1 + std::erf(d / (sigma * std::sqrt(2.0))));
      px[static_cast<size_t>(v * kSize + u)] =
          static_cast<std::uint8_t>(std::lround(kDark + (kBright - kDark) * light + noise(rng)));
    }
  const Points2 c = AllCrossings({px.data(), kSize, kSize}, kLevel);
  ASSERT_GE(c.cols(), 320);  // both sides of the ~80 rows and ~80 columns it covers
  double sum = 0, worst = 0;
  for (Eigen::Index i = 0; i < c.cols(); ++i) {
    const double d = std::hypot(c(0, i) - cx, c(1, i) - cy) - r;
    sum += d, worst = std::max(worst, std::abs(d));
  }
  EXPECT_NEAR(sum / static_cast<double>(c.cols()), 0.0, kCircleBiasTolPx);
  EXPECT_LT(worst, 0.5);  // where a line grazes the circle its crossing is shallow
}

// The level between shadow and light from the image: its 2nd and 98th percentiles' middle,
// whatever a few outliers (a speck of dust at 0, a glint at 255) do.
TEST(Contour, HalfLevelSitsBetweenShadowAndLight) {
  std::vector<std::uint8_t> px(100 * 100, 210);
  std::fill(px.begin(), px.begin() + 4000, 25);
  px[5000] = 0, px[6000] = 255;
  const GreyView im{px.data(), 100, 100};
  EXPECT_DOUBLE_EQ(HalfLevel(im), (25 + 210) / 2.0);
  EXPECT_DOUBLE_EQ(HalfLevel(im.Window(0, 50, 100, 50)), 210.0);  // light only
}

TEST(Contour, NoCrossingNoPoint) {
  const std::vector<std::uint8_t> dark(100, 20);
  EXPECT_EQ(RowCrossings({dark.data(), 10, 10}, kLevel).cols(), 0);
  EXPECT_EQ(ColumnCrossings({dark.data(), 10, 10}, kLevel).cols(), 0);
  EXPECT_EQ(AllCrossings({dark.data(), 10, 10}, kLevel).cols(), 0);
}

}  // namespace
}  // namespace mlp::geometry
