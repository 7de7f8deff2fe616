// The stripe extractor on synthetic rows with known centres: accuracy, and every reject reason.

#include "mlp/probe_fw/stripe.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>
#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

constexpr double kCentreTolPx = 0.01;  // noiseless 16-bit rows: method error only

// One row per entry: a Gaussian stripe (1/e^2 half-width 2 px, i.e. sigma 1 px) of `peak` DN at
// `centre` plus `extra` (a second stripe) on a 100 DN background, 16 bits.
Frame Rows(const std::vector<std::pair<double, double>>& stripes,
           double extra_at = -1,
           double extra_peak = 0) {
  Frame f;
  f.aoi = {10, 20, 64, static_cast<int>(stripes.size())};
  f.bit_depth = 16;
  f.laser_column = 100.0;
  for (const auto& [centre, peak] : stripes) {
    for (int x = 0; x < 64; ++x) {
      double v = 100.0 + peak * std::exp(-0.5 * (x - centre) * (x - centre));
      if (extra_at >= 0) v += extra_peak * std::exp(-0.5 * (x - extra_at) * (x - extra_at));
      f.pixels.push_back(static_cast<std::uint16_t>(std::min(65535.0, std::round(v))));
    }
  }
  return f;
}

TEST(Stripe, SubPixelCentresOfCleanStripes) {
  std::vector<std::pair<double, double>> rows;
  for (int k = 0; k < 21; ++k) rows.push_back({30.0 + 0.05 * k, 20000.0});
  const Frame f = Rows(rows);
  std::vector<StripePoint> points;
  StripeCounts counts;
  ExtractStripe(f, RowMask::Full(f.aoi), {}, &points, &counts);
  ASSERT_EQ(points.size(), rows.size());
  for (size_t i = 0; i < points.size(); ++i) {
    EXPECT_NEAR(points[i].x_px, rows[i].first + 10.0, kCentreTolPx);  // AOI offset added
    EXPECT_EQ(points[i].y_px, static_cast<int>(i) + 20);
  }
}

// The row scan's reasons, on frames one row high (a column scan there sees runs of one pixel,
// cut by the frame's edge: it is left out).
TEST(Stripe, EveryRejectReasonIsCounted) {
  StripeCounts counts;
  std::vector<StripePoint> points;
  StripeOptions rows;
  rows.axes = StripeAxes::kRows;
  ExtractStripe(Rows({{30.0, 10.0}}), RowMask::Full(Rows({{30.0, 10.0}}).aoi), rows, &points,
                &counts);
  EXPECT_EQ(counts.weak + counts.points, 0u);  // below threshold: not even a candidate
  const Frame saturated = Rows({{30.0, 200000.0}});
  ExtractStripe(saturated, RowMask::Full(saturated.aoi), rows, &points, &counts);
  EXPECT_EQ(counts.saturated, 1u);
  const Frame twin = Rows({{30.0, 20000.0}}, 35.0, 15000.0);
  ExtractStripe(twin, RowMask::Full(twin.aoi), rows, &points, &counts);
  EXPECT_EQ(counts.double_peak, 1u);
  const Frame edge = Rows({{2.0, 20000.0}});
  ExtractStripe(edge, RowMask::Full(edge.aoi), rows, &points, &counts);
  EXPECT_EQ(counts.cut, 1u);
  Frame wide = Rows({{30.0, 0.0}});
  for (int x = 10; x < 40; ++x) wide.pixels[static_cast<size_t>(x)] = 20000;  // a smear
  ExtractStripe(wide, RowMask::Full(wide.aoi), rows, &points, &counts);
  EXPECT_EQ(counts.too_wide + counts.saturated, 1u);
  EXPECT_TRUE(points.empty());
}

TEST(Stripe, OnlyMaskedPixelsAreRead) {
  const Frame f = Rows({{30.0, 20000.0}, {30.0, 20000.0}});
  RowMask mask = RowMask::Full(f.aoi);
  mask.rows[0] = {{40, 64}};  // row 0: the stripe is outside its span
  std::vector<StripePoint> points;
  StripeCounts counts;
  ExtractStripe(f, mask, {}, &points, &counts);
  ASSERT_EQ(points.size(), 1u);
  EXPECT_EQ(points[0].y_px, 21);
}

// A straight Gaussian stripe (sigma 1 px across) of 20000 DN on 100 DN, 16 bits, through `centre`
// at `angle_deg` from the sensor's x axis (0: along the rows, 90: down the image).
Frame Line(int width, int height, Eigen::Vector2d centre, double angle_deg) {
  const double a = angle_deg * M_PI / 180.0;
  const Eigen::Vector2d d(std::cos(a), std::sin(a));
  Frame f;
  f.aoi = {5, 7, width, height};
  f.bit_depth = 16;
  f.laser_column = 10.0;
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const Eigen::Vector2d p(x + f.aoi.x0 - centre.x(), y + f.aoi.y0 - centre.y());
      const double across = p.x() * d.y() - p.y() * d.x();
      f.pixels.push_back(static_cast<std::uint16_t>(
          std::round(100.0 + 20000.0 * std::exp(-0.5 * across * across))));
    }
  }
  return f;
}

TEST(Stripe, AStripeAlongTheRowsIsFoundDownTheColumns) {
  const Frame f = Line(64, 48, {40.0, 30.3}, 1.0);
  std::vector<StripePoint> points;
  StripeCounts counts;
  ExtractStripe(f, RowMask::Full(f.aoi), {}, &points, &counts);
  ASSERT_EQ(points.size(), 64u);  // one per sensor column
  for (const StripePoint& p : points) {
    EXPECT_EQ(p.axis, ScanAxis::kColumn);
    EXPECT_EQ(p.x_px, std::round(p.x_px));
    EXPECT_NEAR(p.y_px, 30.3 + std::tan(M_PI / 180.0) * (p.x_px - 40.0), kCentreTolPx);
  }
  // The row scan alone sees the stripe along its rows: at most the rows where the ridge's top
  // lies in the frame, as a bump of under 1 % of the stripe's light (a poorly conditioned centre).
  StripeOptions rows;
  rows.axes = StripeAxes::kRows;
  points.clear();
  ExtractStripe(f, RowMask::Full(f.aoi), rows, &points, &counts);
  EXPECT_LE(points.size(), 2u);
  for (const StripePoint& p : points) EXPECT_LT(p.amplitude_dn, 0.01 * 20000.0);
}

// The frame's transpose, pixel by pixel (the AOI's corner swapped too).
Frame TransposedFrame(const Frame& f) {
  Frame t = f;
  t.aoi = {f.aoi.y0, f.aoi.x0, f.aoi.height, f.aoi.width};
  for (int y = 0; y < f.aoi.height; ++y) {
    for (int x = 0; x < f.aoi.width; ++x)
      t.pixels[static_cast<size_t>(x) * static_cast<size_t>(f.aoi.height) + y] = f.At(x, y);
  }
  return t;
}

// The column scan reads a transposed copy of the frame, built in blocks of 8 x 8 (registers)
// and pixel by pixel at the rims: on a frame of no multiple of 8 either way it finds exactly
// what the row scan finds on the frame transposed here pixel by pixel.
TEST(Stripe, TheColumnScanIsTheRowScanOfTheTransposedFrame) {
  const Frame f = Line(203, 45, {90.0, 29.6}, 4.0);
  StripeOptions columns, rows;
  columns.axes = StripeAxes::kColumns, rows.axes = StripeAxes::kRows;
  std::vector<StripePoint> down, across;
  StripeCounts counts;
  ExtractStripe(f, RowMask::Full(f.aoi), columns, &down, &counts);
  const Frame t = TransposedFrame(f);
  ExtractStripe(t, RowMask::Full(t.aoi), rows, &across, &counts);
  ASSERT_GT(down.size(), 150u);
  ASSERT_EQ(down.size(), across.size());
  for (size_t k = 0; k < down.size(); ++k) {
    EXPECT_EQ(down[k].x_px, across[k].y_px);
    EXPECT_EQ(down[k].y_px, across[k].x_px);
    EXPECT_EQ(down[k].amplitude_dn, across[k].amplitude_dn);
    EXPECT_EQ(down[k].variance_px2, across[k].variance_px2);
  }
}

// At any angle every scan line the stripe crosses gives one centre on it, from the scan more
// nearly across the stripe: none twice (both scans), none lost between them. 45 deg itself is
// a tie either scan may take.
constexpr double kAngledCentreTolPx = 0.02;  // method error on a point-sampled 16-bit stripe
constexpr int kEdgePx = 8;                   // the centroid and direction windows fit inside

TEST(Stripe, EachCrossingOnceAtAnyAngle) {
  for (double angle : {0.0, 15.0, 30.0, 40.0, 50.0, 60.0, 75.0, 90.0, 120.0, 165.0}) {
    const Eigen::Vector2d centre(5 + 48.4, 7 + 47.7);
    const Frame f = Line(96, 96, centre, angle);
    std::vector<StripePoint> points;
    StripeCounts counts;
    ExtractStripe(f, RowMask::Full(f.aoi), {}, &points, &counts);
    const double a = angle * M_PI / 180.0;
    const bool down_the_image = std::abs(std::sin(a)) > std::abs(std::cos(a));
    int interior = 0;
    for (const StripePoint& p : points) {
      const Eigen::Vector2d r(p.x_px - centre.x(), p.y_px - centre.y());
      EXPECT_NEAR(r.x() * std::sin(a) - r.y() * std::cos(a), 0.0, kAngledCentreTolPx)
          << angle << " deg";
      EXPECT_EQ(p.axis, down_the_image ? ScanAxis::kRow : ScanAxis::kColumn) << angle << " deg";
      const double line = p.Line() - (down_the_image ? f.aoi.y0 : f.aoi.x0);
      interior += line >= kEdgePx && line < 96 - kEdgePx;
    }
    // Lines of the owning scan inside the edge whose crossing lies in the frame too.
    int expected = 0;
    for (int line = kEdgePx; line < 96 - kEdgePx; ++line) {
      const double v = line + (down_the_image ? f.aoi.y0 : f.aoi.x0);
      const double along = down_the_image
                               ? centre.x() + (v - centre.y()) * std::cos(a) / std::sin(a)
                               : centre.y() + (v - centre.x()) * std::sin(a) / std::cos(a);
      const double origin = down_the_image ? f.aoi.x0 : f.aoi.y0;
      expected += along - origin >= kEdgePx && along - origin < 96 - kEdgePx;
    }
    EXPECT_GE(interior, expected) << angle << " deg";
    for (size_t i = 0; i < points.size(); ++i) {
      for (size_t j = i + 1; j < points.size(); ++j) {
        EXPECT_GT(std::hypot(points[i].x_px - points[j].x_px, points[i].y_px - points[j].y_px), 0.5)
            << angle << " deg: the same crossing twice";
      }
    }
  }
}

// A row crossing a stripe 60 deg from its normal sees a profile twice as wide, whose tails the
// centroid window cuts: method error up to 0.025 px here (0.02 at 30 deg to the column scan).
constexpr double kInclinedCentreTolPx = 0.03;

TEST(Stripe, TheEpipolarScanOwnsEveryCrossingButAStripeAlongItsLines) {
  // Rows are the epipolar lines; the column scan takes a stripe only where it crosses the
  // columns three times more squarely (about 72 deg from the rows' normal and beyond).
  StripeOptions epipolar_rows;
  epipolar_rows.epipolar_axis = ScanAxis::kRow;
  epipolar_rows.cross_scan_dominance = 3.0;
  for (double angle : {30.0, 40.0, 150.0, 5.0, 170.0}) {
    const Eigen::Vector2d centre(5 + 48.4, 7 + 47.7);
    const Frame f = Line(96, 96, centre, angle);
    std::vector<StripePoint> points;
    StripeCounts counts;
    ExtractStripe(f, RowMask::Full(f.aoi), epipolar_rows, &points, &counts);
    const double a = angle * M_PI / 180.0;
    const bool near_the_rows = std::abs(std::sin(a)) < std::sin(20.0 * M_PI / 180.0);
    ASSERT_GT(points.size(), 40u) << angle << " deg";
    for (const StripePoint& p : points) {
      const Eigen::Vector2d r(p.x_px - centre.x(), p.y_px - centre.y());
      EXPECT_NEAR(r.x() * std::sin(a) - r.y() * std::cos(a), 0.0, kInclinedCentreTolPx)
          << angle << " deg";
      EXPECT_EQ(p.axis, near_the_rows ? ScanAxis::kColumn : ScanAxis::kRow) << angle << " deg";
    }
  }
}

TEST(Stripe, TheColumnScanReadsOnlyTheMask) {
  const Frame f = Line(64, 48, {40.0, 30.0}, 0.0);
  RowMask mask = RowMask::Full(f.aoi);
  for (auto& row : mask.rows) row = {{0, 20}};  // columns 20..63 left out
  const RowMask t = Transposed(mask);
  ASSERT_EQ(t.rows.size(), 64u);
  EXPECT_EQ(t.rows[19], (std::vector<std::pair<int, int>>{{0, 48}}));
  EXPECT_TRUE(t.rows[20].empty());
  std::vector<StripePoint> points;
  StripeCounts counts;
  ExtractStripe(f, mask, {}, &points, &counts);
  ASSERT_EQ(points.size(), 20u);
  for (const StripePoint& p : points) EXPECT_LT(p.x_px, f.aoi.x0 + 20);
}

}  // namespace
}  // namespace mlp::probe_fw

namespace mlp::probe_fw {
namespace {

// Smoothing along the stripe (StripeOptions::along_stripe_sigma_px) and its shift taken out
// (along_blur.h): a stripe crossing the rows at a slope, its light rippling as speckle grains do
// and fading to nothing as at a sphere's limb. The smoothed centre alone is that of lines M1
// away (~1 line where the light fades): slope 0.4 px/line moves it 0.4 px there.
constexpr double kSmoothedCentreTolPx = 0.03;  // noiseless 16-bit: the linear model's error
constexpr double kSlopePxPerLine = 0.4;
// Past the stripe's end (line 70) the smoothing still shows light for ~2 sigma with none of the
// line's own: those centres are extrapolated, 0.3 px off (2.4 px uncorrected; along_blur.h).
constexpr double kPastTheEndTolPx = 0.35;
constexpr double kStripeEndLine = 70.0;

Frame FadingSlopedStripe(int width, int height) {
  Frame f;
  f.aoi = {0, 0, width, height};
  f.bit_depth = 16;
  f.laser_column = 100.0;
  for (int y = 0; y < height; ++y) {
    const double centre = 10.0 + kSlopePxPerLine * y;
    const double fade = std::clamp((kStripeEndLine - y) / 25.0, 0.0, 1.0);
    const double peak = 20000.0 * fade * (1.0 + 0.3 * std::sin(1.3 * y));
    for (int x = 0; x < width; ++x)
      f.pixels.push_back(static_cast<std::uint16_t>(
          std::round(100.0 + peak * std::exp(-0.5 * (x - centre) * (x - centre)))));
  }
  return f;
}

TEST(Stripe, SmoothingAlongAFadingSlopedStripeLeavesItsCentres) {
  const Frame f = FadingSlopedStripe(64, 100);
  StripeOptions o;
  o.axes = StripeAxes::kRows;
  o.along_stripe_sigma_px = 3.0;  // kernel 19 lines: lines 0..8 and 91..99 read past the AOI
  std::vector<StripePoint> points;
  StripeCounts counts;
  ExtractStripe(f, RowMask::Full(f.aoi), o, &points, &counts);
  ASSERT_GT(points.size(), 40u);
  double largest_m1 = 0.0;
  for (const StripePoint& p : points) {
    EXPECT_GE(p.y_px, 9.0) << "the kernel read past the AOI's edge: a cut centre";
    const bool own_light = p.y_px < kStripeEndLine - 8.0;  // a third of full light or more
    EXPECT_NEAR(p.x_px, 10.0 + kSlopePxPerLine * p.y_px,
                own_light ? kSmoothedCentreTolPx : kPastTheEndTolPx)
        << "line " << p.y_px;
    if (own_light) largest_m1 = std::max(largest_m1, std::abs(p.blur_m1_lines));
  }
  // 0.5 lines at 0.4 px/line: 0.2 px uncorrected, 7 x the tolerance.
  EXPECT_GT(largest_m1, 0.5) << "the case must exercise the shift it tests";
  EXPECT_GE(counts.cut, 9u);
}

}  // namespace
}  // namespace mlp::probe_fw
