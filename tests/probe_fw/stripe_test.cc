// The stripe extractor on synthetic rows with known centres: accuracy, and every reject reason.

#include "mlp/probe_fw/stripe.h"

#include <cmath>

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

TEST(Stripe, EveryRejectReasonIsCounted) {
  StripeCounts counts;
  std::vector<StripePoint> points;
  ExtractStripe(Rows({{30.0, 10.0}}), RowMask::Full(Rows({{30.0, 10.0}}).aoi), {}, &points,
                &counts);
  EXPECT_EQ(counts.weak + counts.points, 0u);  // below threshold: not even a candidate
  const Frame saturated = Rows({{30.0, 200000.0}});
  ExtractStripe(saturated, RowMask::Full(saturated.aoi), {}, &points, &counts);
  EXPECT_EQ(counts.saturated, 1u);
  const Frame twin = Rows({{30.0, 20000.0}}, 35.0, 15000.0);
  ExtractStripe(twin, RowMask::Full(twin.aoi), {}, &points, &counts);
  EXPECT_EQ(counts.double_peak, 1u);
  const Frame edge = Rows({{2.0, 20000.0}});
  ExtractStripe(edge, RowMask::Full(edge.aoi), {}, &points, &counts);
  EXPECT_EQ(counts.cut, 1u);
  Frame wide = Rows({{30.0, 0.0}});
  for (int x = 10; x < 40; ++x) wide.pixels[static_cast<size_t>(x)] = 20000;  // a smear
  ExtractStripe(wide, RowMask::Full(wide.aoi), {}, &points, &counts);
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

}  // namespace
}  // namespace mlp::probe_fw
