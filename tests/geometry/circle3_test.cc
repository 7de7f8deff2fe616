// The circle in space under its two definitions (fit.h, Circle3Definition): ISO 10360-6's
// spatial circle (the default) and NIST's plane-then-circle. Where the points are coplanar they
// agree; on a lobed, warped ring they differ by a predictable tilt, which the spatial circle
// does not have.

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <cmath>
#include <cstdio>

#include "nist_data.h"
#include "nullspace.h"
#include "seeded_draw.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kPositionTolMm = 1e-4;  // 0.1 um (TraCIM's tightest limit)
constexpr double kAngleTolRad = 1e-7;    // 0.1 urad
constexpr double kSameMm = 1e-9;         // two solvers reaching one optimum: rounding
constexpr double kSameRad = 1e-10;

double AngleUpToSign(const Vec3& a, const Vec3& b) {
  return std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

// Sum of squared 3D distances (SignedDistance of a Circle3 is the spatial distance).
double SpatialSumSq(const Circle3& c, const Points3& pts) {
  double ss = 0.0;
  for (Eigen::Index i = 0; i < pts.cols(); ++i) ss += std::pow(SignedDistance(c, pts.col(i)), 2);
  return ss;
}

FitOptions PlaneThenCircle() {
  FitOptions o;
  o.circle3 = Circle3Definition::kPlaneThenCircle;
  return o;
}

// A ring of radius R lobed in its plane (radial a = A cos 3t) and warped out of it (height
// h = A cos 2t), n points evenly spaced: both deviations are orthogonal to (1, cos t, sin t),
// so the true circle is the spatial least-squares circle (nullspace_test.cc, Circle3Spatial).
// The plane fit is tilted instead: its scatter has the cross term sum a h cos t = n A^2 / 4
// against sum x^2 = n R^2 / 2, a tilt of A^2 / (2 R^2).
struct WarpedRing {
  Circle3 truth;
  double amplitude_mm;
  Points3 points;
};

WarpedRing MakeWarpedRing(int n, double radius_mm, double amplitude_mm, std::mt19937_64& rng) {
  WarpedRing ring{{test::RandomDirection(rng) * 800.0, test::RandomDirection(rng), radius_mm},
                  amplitude_mm,
                  Points3(3, n)};
  Vec3 u, v;
  test::Frame(ring.truth.normal, &u, &v);
  for (int i = 0; i < n; ++i) {
    const double t = 2.0 * M_PI * i / n;
    const double a = amplitude_mm * std::cos(3.0 * t), h = amplitude_mm * std::cos(2.0 * t);
    ring.points.col(i) = ring.truth.center + (radius_mm + a) * (std::cos(t) * u + std::sin(t) * v) +
                         h * ring.truth.normal;
  }
  return ring;
}

TEST(Circle3Definitions, DifferByAPredictedTiltOnAWarpedRing) {
  std::mt19937_64 rng(20261126u);
  // A 50 mm ring with 50 um of lobing and warp: a thin turned ring out of its chuck.
  const WarpedRing ring = MakeWarpedRing(360, 25.0, 0.05, rng);
  const auto spatial = FitCircle3(ring.points);
  EXPECT_LT((spatial.shape.center - ring.truth.center).norm(), kPositionTolMm);
  EXPECT_LT(AngleUpToSign(spatial.shape.normal, ring.truth.normal), kAngleTolRad);
  EXPECT_NEAR(spatial.shape.radius, ring.truth.radius, kPositionTolMm);

  const auto plane_first = FitCircle3(ring.points, PlaneThenCircle());
  const double tilt = AngleUpToSign(plane_first.shape.normal, ring.truth.normal);
  const double predicted = ring.amplitude_mm * ring.amplitude_mm / (2.0 * 25.0 * 25.0);
  std::printf("plane-then-circle tilt %.3g rad (predicted %.3g), spatial %.3g rad\n", tilt,
              predicted, AngleUpToSign(spatial.shape.normal, ring.truth.normal));
  EXPECT_NEAR(tilt, predicted, 0.05 * predicted);
  EXPECT_GT(tilt, 10.0 * kAngleTolRad) << "the two definitions must be told apart here";
  // NIST's normal is the least-squares plane's, by definition.
  EXPECT_LT(AngleUpToSign(plane_first.shape.normal, FitPlane(ring.points).shape.normal), kSameRad);
  EXPECT_LT(SpatialSumSq(spatial.shape, ring.points), SpatialSumSq(plane_first.shape, ring.points));
}

TEST(Circle3Definitions, AgreeOnCoplanarPoints) {
  std::mt19937_64 rng(7u);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Circle3 truth{Vec3(120.0, -40.0, 300.0), Vec3(0.3, -0.2, 0.9).normalized(), 6.0};
  Vec3 u, v;
  test::Frame(truth.normal, &u, &v);
  Points3 pts(3, 40);
  for (int i = 0; i < pts.cols(); ++i) {  // a 120 deg arc, 10 um of in-plane noise
    const double t = 2.0 * M_PI / 3.0 * i / 39.0;
    const double r = truth.radius + noise(rng);
    pts.col(i) = truth.center + r * (std::cos(t) * u + std::sin(t) * v);
  }
  const auto spatial = FitCircle3(pts);
  const auto plane_first = FitCircle3(pts, PlaneThenCircle());
  EXPECT_LT((spatial.shape.center - plane_first.shape.center).norm(), kSameMm);
  EXPECT_LT(AngleUpToSign(spatial.shape.normal, plane_first.shape.normal), kSameRad);
  EXPECT_NEAR(spatial.shape.radius, plane_first.shape.radius, kSameMm);
  EXPECT_NEAR(spatial.stats.rms, plane_first.stats.rms, kSameMm);
}

// NIST's Circle3d sets are fitted plane-first (nist_test.cc checks that to 0.1 um / 0.1 urad).
// The spatial circle of the same points has a smaller spatial sum of squares wherever they
// differ; the differences are printed for docs/GEOMETRY.md.
TEST(Circle3Definitions, NistSetsUnderTheSpatialDefinition) {
  for (const char* name : {"cir5", "cir7", "cir10", "cir20", "cir22", "cir25"}) {
    const auto dir = test::RepoDataDir() / "nist" / "Circle3d";
    const Points3 pts = test::ReadNistDs(dir / (std::string(name) + ".ds"));
    const std::vector<double> ref = test::ReadNistFit(dir / (std::string(name) + ".fit"));
    ASSERT_EQ(ref.size(), 7u) << name;
    const Circle3 nist{Vec3(ref[0], ref[1], ref[2]), Vec3(ref[3], ref[4], ref[5]), ref[6] / 2};
    const auto spatial = FitCircle3(pts);
    const double ss_spatial = SpatialSumSq(spatial.shape, pts), ss_nist = SpatialSumSq(nist, pts);
    std::printf("%-5s n %3ld  normal %.3g rad  centre %.3g mm  diameter %+.3g mm  SS %.6g / %.6g\n",
                name, static_cast<long>(pts.cols()),
                AngleUpToSign(spatial.shape.normal, nist.normal),
                (spatial.shape.center - nist.center).norm(), 2 * spatial.shape.radius - ref[6],
                ss_spatial, ss_nist);
    EXPECT_TRUE(spatial.stats.converged) << name;
    // Floor: NIST's parameters are printed to about 1e-9 mm, so its circle's own sum carries
    // that rounding (cir22 lies 4 nm RMS from its circle: there the two definitions coincide).
    const double floor_mm2 = static_cast<double>(pts.cols()) * 1e-18;
    EXPECT_LE(ss_spatial, ss_nist * (1.0 + 1e-12) + floor_mm2) << name;
  }
}

// Residuals are signed 3D distances: outside the circle's cylinder positive. Radial a = d cos 4t,
// height h = e cos 2t at 8 even angles: the truth is the fit, and at t = 0 the point is outside
// and above (hypot(d, e)), at 45 deg inside in the plane (-d).
TEST(Circle3Definitions, SpatialResidualsAreSignedDistances) {
  const double d = 0.003, e = 0.004, radius = 10.0;
  Points3 pts(3, 8);
  for (int i = 0; i < 8; ++i) {
    const double t = M_PI / 4.0 * i;
    pts.col(i) = Vec3((radius + d * std::cos(4 * t)) * std::cos(t),
                      (radius + d * std::cos(4 * t)) * std::sin(t), e * std::cos(2 * t));
  }
  const auto fit = FitCircle3(pts);
  EXPECT_NEAR(fit.shape.radius, radius, kSameMm);
  EXPECT_NEAR(fit.stats.max_residual, std::hypot(d, e), kSameMm);
  EXPECT_NEAR(fit.stats.min_residual, -d, kSameMm);
  EXPECT_NEAR(fit.stats.rms * fit.stats.rms * 8, SpatialSumSq(fit.shape, pts), 1e-15);
  EXPECT_EQ(fit.covariance.parameters.size(), 6u);
  EXPECT_EQ(fit.covariance.matrix.rows(), 6);
}

TEST(Circle3Definitions, RobustFitKeepsTheSpatialOptimumOfItsInliers) {
  std::mt19937_64 rng(11u);
  WarpedRing ring = MakeWarpedRing(120, 25.0, 0.02, rng);
  Points3 pts(3, ring.points.cols() + 12);
  pts.leftCols(ring.points.cols()) = ring.points;
  for (int k = 0; k < 12; ++k)  // reflections 2-3 mm off the ring
    pts.col(ring.points.cols() + k) =
        ring.points.col(10 * k) + (2.0 + 0.1 * k) * test::RandomDirection(rng);
  RobustOptions options;
  options.inlier_threshold_mm = 0.2;
  const auto robust = FitCircle3Robust(pts, options);
  EXPECT_EQ(robust.inliers.size(), static_cast<size_t>(ring.points.cols()));
  EXPECT_LT((robust.fit.shape.center - ring.truth.center).norm(), kPositionTolMm);
  EXPECT_LT(AngleUpToSign(robust.fit.shape.normal, ring.truth.normal), kAngleTolRad);
}

TEST(Circle3Definitions, AnUnknownDefinitionIsAnInvalidArgument) {
  std::mt19937_64 rng(3u);
  FitOptions options;
  options.circle3 = static_cast<Circle3Definition>(7);
  try {
    FitCircle3(MakeWarpedRing(12, 5.0, 0.0, rng).points, options);
    FAIL() << "an unknown definition was accepted";
  } catch (const GeometryError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
  }
}

}  // namespace
}  // namespace mlp::geometry
