// Features from points in the machine frame: a bore segmented by its nominal and fitted, with
// its functional size, against known truth (synthetic points with noise, the rim face, chips).

#include "mlp/features/feature.h"

#include <random>

#include "feature_points.h"
#include "seeded_draw.h"
#include <gtest/gtest.h>

namespace mlp::features {
namespace {

using geometry::Vec3;

constexpr double kNoiseMm = 0.002;
constexpr double kDiameterTolMm = 0.0005;  // 4,000 points at 2 um noise: a fraction of a um
constexpr double kCentreTolMm = 0.001;
constexpr double kAxisTol = 1e-6;      // a bore's axis against +Z (unit vector)
constexpr double kArcTolDeg = 1.0;     // the wall's arc seen
constexpr double kNormalTol = 1e-9;    // a face's normal against the true one (unit vector)
constexpr double kFaceTolMm = 0.0002;  // where the face is

// A bore of `diameter` around (cx, cy), top face z = 0, seen over `span_deg` of its wall, plus
// points of the top face around the rim and chips inside.
geometry::Points3 BorePoints(double diameter, double cx, double cy, double span_deg, int seed) {
  std::mt19937 rng(static_cast<unsigned>(seed));
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::uniform_real_distribution<double> angle(0, span_deg * M_PI / 180), depth(-28, -1.5),
      unit(0, 1);
  std::vector<Vec3> p;
  for (int i = 0; i < 4000; ++i) {
    const double a = angle(rng), r = diameter / 2 + noise(rng);
    p.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a), depth(rng));
  }
  for (int i = 0; i < 2000; ++i) {  // the top face around the rim
    const double a = angle(rng), r = diameter / 2 + 0.3 + 5 * unit(rng);
    p.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a), noise(rng));
  }
  for (int i = 0; i < 40; ++i) {  // chips stuck to the wall: 0.2-0.4 mm proud
    const double a = angle(rng), r = diameter / 2 - 0.2 - 0.2 * unit(rng);
    p.emplace_back(cx + r * std::cos(a), cy + r * std::sin(a), depth(rng));
  }
  geometry::Points3 m(3, static_cast<Eigen::Index>(p.size()));
  for (size_t i = 0; i < p.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = p[i];
  return m;
}

TEST(Bore, SizePositionAndFunctionalSize) {
  BoreNominal n;
  n.diameter_mm = 60.0, n.depth_mm = 30.0;
  n.band_mm = 0.15;  // chips 0.2 mm proud fall outside the band
  const BoreMeasurement m = MeasureBore(BorePoints(59.994, 0.012, -0.007, 360, 1), n);
  EXPECT_NEAR(m.diameter_mm, 59.994, kDiameterTolMm);
  EXPECT_NEAR(m.top_centre_mcs.x(), 0.012, kCentreTolMm);
  EXPECT_NEAR(m.top_centre_mcs.y(), -0.007, kCentreTolMm);
  EXPECT_NEAR(m.axis_mcs.z(), 1.0, kAxisTol);
  EXPECT_EQ(m.points, 4000);  // the face and the chips left out
  EXPECT_GT(m.arc_span_deg, 359.0);
  EXPECT_NEAR(m.rms_mm, kNoiseMm, 0.2 * kNoiseMm);
  // The largest pin is smaller than the least-squares size by about the noise's reach.
  EXPECT_LT(m.functional_diameter_mm, m.diameter_mm);
  EXPECT_GT(m.functional_diameter_mm, m.diameter_mm - 8 * kNoiseMm);
}

TEST(Bore, ShortArcsAndMissingWallsAreSaid) {
  BoreNominal n;
  n.diameter_mm = 60.0, n.depth_mm = 30.0;
  const BoreMeasurement arc = MeasureBore(BorePoints(60.0, 0, 0, 150, 2), n);
  EXPECT_NEAR(arc.arc_span_deg, 150.0, kArcTolDeg);
  EXPECT_EQ(arc.functional_diameter_mm, 0.0);  // no functional size from under half a circle
  n.top_centre_mcs = Vec3(80, 0, 0);           // the wrong bore
  try {
    MeasureBore(BorePoints(60.0, 0, 0, 360, 3), n);
    ADD_FAILURE() << "measured a bore that is not there";
  } catch (const FeatureError& e) {
    EXPECT_NE(std::string(e.what()).find("points on the nominal wall"), std::string::npos);
  }
  n = {};
  EXPECT_THROW(MeasureBore(BorePoints(60.0, 0, 0, 360, 4), n), FeatureError);  // no nominal
}

// A three-lobed bore (r = R + A cos 3t at every depth, sampled every degree, so the six
// extremes are points): its minimum zone is 2 A, centred, whatever the depth.
TEST(Bore, CylindricityOfALobedWallWhenAsked) {
  constexpr double kLobeMm = 0.004, kRadiusMm = 20.0;
  constexpr double kZoneTolMm = 1e-7;  // exact data: the Chebyshev fit's own precision
  std::vector<Vec3> p;
  for (int depth = 2; depth <= 28; depth += 2) {
    for (int deg = 0; deg < 360; ++deg) {
      const double t = deg * M_PI / 180, r = kRadiusMm + kLobeMm * std::cos(3 * t);
      p.emplace_back(r * std::cos(t), r * std::sin(t), -depth);
    }
  }
  geometry::Points3 m(3, static_cast<Eigen::Index>(p.size()));
  for (size_t i = 0; i < p.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = p[i];
  BoreNominal n;
  n.diameter_mm = 40.0, n.depth_mm = 30.0;
  EXPECT_EQ(MeasureBore(m, n).cylindricity_mm, 0.0);  // not asked: no Chebyshev fit
  n.cylindricity = true;
  const BoreMeasurement b = MeasureBore(m, n);
  EXPECT_NEAR(b.cylindricity_mm, 2 * kLobeMm, kZoneTolMm);
  EXPECT_TRUE(b.cylindricity_converged);
}

TEST(Boss, SizePositionAndSmallestRing) {
  // A D30.008 boss at (0.01, -0.02), its wall from z = -20 to -1, its top face and the floor
  // around it in the cloud.
  test::CloudMaker cloud(11, kNoiseMm);
  cloud.Wall(0.01, -0.02, 15.004, -20, -1, 0, 360, 4000);
  cloud.Patch(Vec3(-10, -10, 0), Vec3::UnitX(), Vec3::UnitY(), 20, 20, 1000);
  cloud.Patch(Vec3(16, -30, -22), Vec3::UnitX(), Vec3::UnitY(), 10, 60, 1000);
  BoreNominal n;
  n.diameter_mm = 30.0, n.depth_mm = 21.0, n.boss = true;
  const BoreMeasurement m = MeasureBore(cloud.Cloud(), n);
  EXPECT_NEAR(m.diameter_mm, 30.008, kDiameterTolMm);
  EXPECT_NEAR(m.top_centre_mcs.x(), 0.01, kCentreTolMm);
  EXPECT_NEAR(m.top_centre_mcs.y(), -0.02, kCentreTolMm);
  EXPECT_EQ(m.points, 4000);
  // The smallest ring over it is larger than the least-squares size by the noise's reach.
  EXPECT_GT(m.functional_diameter_mm, m.diameter_mm);
  EXPECT_LT(m.functional_diameter_mm, m.diameter_mm + 8 * kNoiseMm);
}

TEST(Plane, FaceThroughChipsAndBurrs) {
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::uniform_real_distribution<double> u(-20, 20);
  const Vec3 normal = Vec3(0.001, -0.002, 1).normalized();  // a face 0.13 deg off level
  std::vector<Vec3> p;
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector2d xy = mlp::test::DrawVec2(u, rng);
    const Vec3 q(xy.x(), xy.y(), 0);
    p.push_back(q - (q.dot(normal) - 5.0 * normal.z()) / normal.z() * Vec3::UnitZ() +
                noise(rng) * normal);
  }
  for (int i = 0; i < 50; ++i) {  // chips, 50 um
    const Eigen::Vector2d xy = mlp::test::DrawVec2(u, rng);
    p.emplace_back(xy.x(), xy.y(), 5.0 + 0.05);
  }
  for (int i = 0; i < 500; ++i) {  // a lower step
    const Eigen::Vector2d xy = mlp::test::DrawVec2(u, rng);
    p.emplace_back(xy.x(), xy.y(), 2.0);
  }
  geometry::Points3 m(3, static_cast<Eigen::Index>(p.size()));
  for (size_t i = 0; i < p.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = p[i];
  PlaneNominal n;
  n.point_mcs = Vec3(0, 0, 5), n.normal_mcs = Vec3::UnitZ();
  n.flatness = true;
  const PlaneMeasurement f = MeasurePlane(m, n);
  EXPECT_NEAR(f.plane.normal.dot(normal), 1.0, kNormalTol);
  EXPECT_NEAR((f.plane.point - Vec3(0, 0, 5)).dot(normal), 0.0, kFaceTolMm);
  EXPECT_NEAR(f.rms_mm, kNoiseMm, 0.2 * kNoiseMm);
  EXPECT_GE(f.trimmed, 50);                   // the chips
  EXPECT_NEAR(f.height_mm, 0.0, kFaceTolMm);  // the face is where the nominal says
  EXPECT_GT(f.flatness_mm, 4 * kNoiseMm);     // the minimum zone spans the noise, +-3.5 sigma
  EXPECT_LT(f.flatness_mm, 10 * kNoiseMm);
  EXPECT_LE(f.points, 5000);    // the step is outside the band
  n.point_mcs = Vec3(0, 0, 8);  // no face there
  EXPECT_THROW(MeasurePlane(m, n), FeatureError);
}

}  // namespace
}  // namespace mlp::features
