// All 37 NIST least-squares reference pairs in ../shared/data/nist must agree with our fits to
// the tightest limits PTB's TraCIM service accepts for ISO 10360-6: 0.1 um and 0.1 urad.

#include "mlp/geometry/fit.h"

#include <vector>

#include "nist_data.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kPositionTolMm = 1e-4;  // 0.1 um
constexpr double kAngleTolRad = 1e-7;    // 0.1 urad
constexpr double kSizeTolMm = 1e-4;      // 0.1 um on diameters and distances

struct NistCase {
  std::string folder;
  std::string name;
};

std::ostream& operator<<(std::ostream& os, const NistCase& c) { return os << c.name; }

double AngleUpToSign(const Vec3& a, const Vec3& b) {
  return std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

double DistanceToAxis(const Vec3& p, const Vec3& point, const Vec3& axis) {
  return (p - point).cross(axis.normalized()).norm();
}

class NistReference : public testing::TestWithParam<NistCase> {};

TEST_P(NistReference, AgreesToTraCimLimits) {
  const auto& c = GetParam();
  const auto dir = test::RepoDataDir() / "nist" / c.folder;
  const Points3 pts = test::ReadNistDs(dir / (c.name + ".ds"));
  const std::vector<double> ref = test::ReadNistFit(dir / (c.name + ".fit"));
  ASSERT_GE(ref.size(), 4u);
  const Vec3 ref_point(ref[0], ref[1], ref[2]);
  const Vec3 ref_dir = ref.size() >= 6 ? Vec3(ref[3], ref[4], ref[5]) : Vec3::Zero();
  if (c.folder == "Line2d") {
    // Drop the coordinate that is constant in the file; fit the 2D line in the other two.
    int keep[2], k = 0;
    for (int i = 0; i < 3; ++i) {
      if (std::abs(ref_dir(i)) > 0.0 || (pts.row(i).maxCoeff() != pts.row(i).minCoeff())) {
        if (k < 2) keep[k++] = i;
      }
    }
    ASSERT_EQ(k, 2);
    Points2 p2(2, pts.cols());
    p2.row(0) = pts.row(keep[0]);
    p2.row(1) = pts.row(keep[1]);
    const auto fit = FitLine2(p2);
    const Vec3 dir3 = [&] {
      Vec3 d = Vec3::Zero();
      d(keep[0]) = fit.shape.direction.x();
      d(keep[1]) = fit.shape.direction.y();
      return d;
    }();
    EXPECT_LT(AngleUpToSign(dir3, ref_dir), kAngleTolRad);
    const Vec2 ref2(ref_point(keep[0]), ref_point(keep[1]));
    EXPECT_LT(std::abs(SignedDistance(fit.shape, ref2)), kPositionTolMm);
  } else if (c.folder == "Line3d") {
    const auto fit = FitLine3(pts);
    EXPECT_LT(AngleUpToSign(fit.shape.direction, ref_dir), kAngleTolRad);
    EXPECT_LT(SignedDistance(fit.shape, ref_point), kPositionTolMm);
  } else if (c.folder == "Plane") {
    const auto fit = FitPlane(pts);
    EXPECT_LT(AngleUpToSign(fit.shape.normal, ref_dir), kAngleTolRad);
    EXPECT_LT(std::abs(SignedDistance(fit.shape, ref_point)), kPositionTolMm);
  } else if (c.folder == "Circle3d") {
    // NIST's circle in space is the plane first, then the circle (their stated method).
    FitOptions nist;
    nist.circle3 = Circle3Definition::kPlaneThenCircle;
    const auto fit = FitCircle3(pts, nist);
    EXPECT_LT((fit.shape.center - ref_point).norm(), kPositionTolMm);
    EXPECT_LT(AngleUpToSign(fit.shape.normal, ref_dir), kAngleTolRad);
    EXPECT_NEAR(2.0 * fit.shape.radius, ref[6], kSizeTolMm);
  } else if (c.folder == "Sphere") {
    const auto fit = FitSphere(pts);
    EXPECT_LT((fit.shape.center - ref_point).norm(), kPositionTolMm);
    EXPECT_NEAR(2.0 * fit.shape.radius, ref[3], kSizeTolMm);
  } else if (c.folder == "Cylinder") {
    const auto fit = FitCylinder(pts);
    EXPECT_LT(AngleUpToSign(fit.shape.axis, ref_dir), kAngleTolRad);
    EXPECT_LT(DistanceToAxis(ref_point, fit.shape.point, fit.shape.axis), kPositionTolMm);
    EXPECT_NEAR(2.0 * fit.shape.radius, ref[6], kSizeTolMm);
  } else if (c.folder == "Cone") {
    const auto fit = FitCone(pts);
    const Cone& cone = fit.shape;
    // Cone axes are oriented (towards growing radius): compare with sign.
    EXPECT_LT(std::acos(std::min(1.0, cone.axis.dot(ref_dir.normalized()))), kAngleTolRad);
    EXPECT_LT(DistanceToAxis(ref_point, cone.point, cone.axis), kPositionTolMm);
    const double t = (ref_point - cone.point).dot(cone.axis);
    EXPECT_NEAR(cone.distance + t * std::sin(cone.half_angle), ref[6], kSizeTolMm);
    EXPECT_NEAR(2.0 * cone.half_angle, ref[7] * M_PI / 180.0, kAngleTolRad);
  } else {
    FAIL() << "unknown folder " << c.folder;
  }
}

std::vector<NistCase> AllCases() {
  std::vector<NistCase> cases;
  const char* sets[][2] = {
      {"Circle3d", "cir5"},  {"Circle3d", "cir7"},  {"Circle3d", "cir10"}, {"Circle3d", "cir20"},
      {"Circle3d", "cir22"}, {"Circle3d", "cir25"}, {"Cone", "con17"},     {"Cone", "con19"},
      {"Cone", "con24"},     {"Cylinder", "cyl21"}, {"Cylinder", "cyl23"}, {"Cylinder", "cyl29"},
      {"Line2d", "lin2d1"},  {"Line2d", "lin2d2"},  {"Line2d", "lin2d3"},  {"Line2d", "lin2d9"},
      {"Line2d", "lin2d10"}, {"Line2d", "lin2d11"}, {"Line2d", "lin2d12"}, {"Line2d", "lin2d16"},
      {"Line2d", "lin2d17"}, {"Line2d", "lin2d19"}, {"Line2d", "lin2d21"}, {"Line2d", "lin2d27"},
      {"Line3d", "lin3"},    {"Line3d", "lin8"},    {"Line3d", "lin17"},   {"Plane", "pla7"},
      {"Plane", "pla8"},     {"Plane", "pla22"},    {"Plane", "pla26"},    {"Sphere", "sph5"},
      {"Sphere", "sph11"},   {"Sphere", "sph14"},   {"Sphere", "sph16"},   {"Sphere", "sph20"},
      {"Sphere", "sph22"}};
  for (const auto& s : sets) cases.push_back({s[0], s[1]});
  return cases;
}

TEST(NistReference, AllThirtySevenPairsArePresent) {
  EXPECT_EQ(AllCases().size(), 37u);
  for (const auto& c : AllCases()) {
    const auto dir = test::RepoDataDir() / "nist" / c.folder;
    EXPECT_TRUE(std::filesystem::exists(dir / (c.name + ".ds"))) << c.name;
    EXPECT_TRUE(std::filesystem::exists(dir / (c.name + ".fit"))) << c.name;
  }
}

INSTANTIATE_TEST_SUITE_P(Nist,
                         NistReference,
                         testing::ValuesIn(AllCases()),
                         [](const auto& test_info) { return test_info.param.name; });

}  // namespace
}  // namespace mlp::geometry
