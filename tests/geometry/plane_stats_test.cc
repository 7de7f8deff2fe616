// The one-pass plane fit reports residual extremes from a second look at a few blocks only
// (FitPlane in fit_linear.cc). These tests compare them, and the RMS from the eigenvalue, with
// a brute-force pass over every point, on clouds built to defeat the block bounds.

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

// Same formula as FitPlane, so only rounding of |p - c| ~ 100 mm can differ: 1e-12 mm.
constexpr double kExtremeTolMm = 1e-12;
// RMS from lambda_min: rounding ~1e-16 x extent^2 / rms on the squared sum (see FitPlane).
constexpr double kRmsTolMm = 1e-9;

struct Truth {
  double rms, min, max;
};

Truth BruteForce(const Points3& points, const Plane& plane) {
  Truth t{0.0, INFINITY, -INFINITY};
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const double r = plane.normal.dot(points.col(i) - plane.point);
    t.rms += r * r, t.min = std::min(t.min, r), t.max = std::max(t.max, r);
  }
  t.rms = std::sqrt(t.rms / static_cast<double>(points.cols()));
  return t;
}

// A tilted plane patch of `n` points, `size_mm` across, `offset_mm` from the origin, with
// Gaussian form noise.
Points3 Patch(
    int n, double size_mm, double offset_mm, double noise_mm, const Vec3& normal, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<double> along(-size_mm / 2, size_mm / 2);
  std::normal_distribution<double> noise(0.0, noise_mm);
  const Vec3 w = normal.normalized();
  const Vec3 u = w.unitOrthogonal(), v = w.cross(u);
  Points3 p(3, n);
  for (int i = 0; i < n; ++i) {
    const double h = noise(gen);  // the last term's draw first: tests/seeded_draw.h
    const double b = along(gen);
    const double a = along(gen);
    p.col(i) = Vec3::Constant(offset_mm) + a * u + b * v + h * w;
  }
  return p;
}

void ExpectExact(const Points3& points) {
  const auto fit = FitPlane(points);
  const Truth t = BruteForce(points, fit.shape);
  EXPECT_NEAR(fit.stats.min_residual, t.min, kExtremeTolMm);
  EXPECT_NEAR(fit.stats.max_residual, t.max, kExtremeTolMm);
  EXPECT_NEAR(fit.stats.rms, t.rms, kRmsTolMm);
  EXPECT_EQ(fit.stats.n, points.cols());
}

TEST(PlaneStats, RandomOrderNoisyPatches) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE(seed);
    const Vec3 normal(0.1 * seed, -0.3, seed % 2 ? 1.0 : -1.0);
    ExpectExact(Patch(40000 + 977 * static_cast<int>(seed), 100.0, seed % 3 ? 0.0 : 1000.0, 0.002,
                      normal, seed));
  }
}

// Sorted by residual: every block's trial interval is narrow and adjacent to the next one's,
// and the extremes sit in the first and last blocks.
TEST(PlaneStats, SortedByResidual) {
  Points3 p = Patch(60000, 80.0, 100.0, 0.005, Vec3(0.2, 0.1, 1.0), 7);
  const auto fit = FitPlane(p);
  std::vector<Eigen::Index> order(static_cast<size_t>(p.cols()));
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<Eigen::Index>(i);
  std::sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) {
    return fit.shape.normal.dot(p.col(a)) < fit.shape.normal.dot(p.col(b));
  });
  Points3 sorted(3, p.cols());
  for (size_t i = 0; i < order.size(); ++i)
    sorted.col(static_cast<Eigen::Index>(i)) = p.col(order[i]);
  ExpectExact(sorted);
  std::reverse(order.begin(), order.end());
  for (size_t i = 0; i < order.size(); ++i)
    sorted.col(static_cast<Eigen::Index>(i)) = p.col(order[i]);
  ExpectExact(sorted);
}

// Every 40th point (what the trial normal samples) lies on one line: the trial normal is then
// arbitrary, and the extremes must still be exact.
TEST(PlaneStats, DegenerateTrialSample) {
  Points3 p = Patch(50000, 100.0, 0.0, 0.003, Vec3(0.0, 0.3, 1.0), 11);
  for (Eigen::Index i = 0; i < p.cols(); i += 1) {
    if (i % 97 == 0) p.col(i) = Vec3(static_cast<double>(i) * 1e-3, 0.0, 0.0);
  }
  ExpectExact(p);
}

// One spike far above the plane among flat points, and a perfectly flat cloud (rms ~ 0).
TEST(PlaneStats, SpikeAndPerfectlyFlat) {
  Points3 p = Patch(30000, 50.0, 500.0, 0.001, Vec3(1.0, 1.0, 1.0), 3);
  p.col(12345) += Vec3(0.3, 0.3, 0.3);
  ExpectExact(p);
  ExpectExact(Patch(30000, 50.0, 0.0, 0.0, Vec3(0.0, 0.0, 1.0), 4));
}

TEST(PlaneStats, SmallCloudsTakeTheDirectPath) {
  for (int n : {3, 4, 10, 1000, 4096, 4097}) {
    SCOPED_TRACE(n);
    ExpectExact(Patch(n, 20.0, 10.0, 0.01, Vec3(0.0, 1.0, 0.2), static_cast<unsigned>(n)));
  }
}

}  // namespace
}  // namespace mlp::geometry
