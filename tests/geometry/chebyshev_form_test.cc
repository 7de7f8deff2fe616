// Minimum-zone sphericity and cylindricity, and the minimum-zone line and circle in the plane,
// against reference data made by construction (as the least-squares sets of nullspace_test.cc):
// contact points on the two bounding surfaces placed so that the known zone is a strict local
// minimum (each side's contact directions positively span the step space, so every step
// widens the zone to first order), filler points strictly inside, a random pose 1000 mm from
// the origin. The fit must return that zone, and no random nearby zone may be narrower.

#include "mlp/geometry/chebyshev.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"

#include <cmath>
#include <cstdio>
#include <random>

#include "nullspace.h"
#include "seeded_draw.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kZoneTolMm = 1e-7;  // 0.1 nm: an exact configuration comes out exact
constexpr double kRefTolMm = 1e-4;   // 0.1 um: the limit for Chebyshev reference data
constexpr double kAngleTolRad = 1e-7;

double AngleUpToSign(const Vec3& a, const Vec3& b) {
  return std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

// A random rotation: columns u, v, w.
Mat3 RandomFrame(std::mt19937_64& rng) {
  Mat3 r;
  r.col(2) = test::RandomDirection(rng);
  Vec3 u, v;
  test::Frame(r.col(2), &u, &v);
  r.col(0) = u, r.col(1) = v;
  return r;
}

Points3 ToColumns(const std::vector<Vec3>& pts) {
  Points3 p(3, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) p.col(static_cast<Eigen::Index>(i)) = pts[i];
  return p;
}

// ---- sphericity ----

struct SphereCase {
  const char* name;
  std::vector<Vec3> outer, inner;  // contact directions (unit), in the sphere's frame
};

std::vector<SphereCase> SphereCases() {
  const double s = 1.0 / std::sqrt(3.0);
  const std::vector<Vec3> tetra{Vec3(s, s, s), Vec3(s, -s, -s), Vec3(-s, s, -s), Vec3(-s, -s, s)};
  std::vector<Vec3> anti;
  for (const Vec3& t : tetra) anti.push_back(-t);
  std::vector<Vec3> equator;
  for (int k = 0; k < 3; ++k)
    equator.push_back(Vec3(std::cos(2 * M_PI * k / 3), std::sin(2 * M_PI * k / 3), 0.0));
  // Two tetrahedra (a cube's corners in turn): 4 + 4 contacts. The poles outside and a
  // triangle on the equator inside: 2 + 3, the fewest that fix a centre and two radii.
  return {{"tetrahedra", tetra, anti},
          {"poles_and_equator", {Vec3::UnitZ(), -Vec3::UnitZ()}, equator}};
}

TEST(MinZoneSphere, ReferenceSpheresByConstruction) {
  for (const SphereCase& c : SphereCases()) {
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      std::mt19937_64 rng(100 + seed);
      const Mat3 frame = RandomFrame(rng);
      const Vec3 centre = test::RandomDirection(rng) * 1000.0;
      const double radius = 5.0 + 10.0 * static_cast<double>(seed), half = 0.002;  // 4 um
      std::vector<Vec3> pts;
      std::uniform_real_distribution<double> uni(-1.0, 1.0);
      for (int i = 0; i < 400; ++i) {
        const double dr = uni(rng);  // one draw per statement: tests/seeded_draw.h
        const Vec3 dir = test::RandomDirection(rng);
        pts.push_back(centre + (radius + 0.9 * half * dr) * dir);
      }
      for (const Vec3& d : c.outer) pts.push_back(centre + (radius + half) * (frame * d));
      for (const Vec3& d : c.inner) pts.push_back(centre + (radius - half) * (frame * d));
      const Points3 p = ToColumns(pts);
      const auto fit = FitMinZoneSphere(p);
      SCOPED_TRACE(std::string(c.name) + " seed " + std::to_string(seed));
      EXPECT_TRUE(fit.stats.converged);
      EXPECT_NEAR(fit.sphericity, 2 * half, kZoneTolMm);
      EXPECT_LT((fit.sphere.center - centre).norm(), kZoneTolMm);
      EXPECT_NEAR(fit.outer_radius, radius + half, kZoneTolMm);
      EXPECT_NEAR(fit.inner_radius, radius - half, kZoneTolMm);
      const auto ls = FitSphere(p);
      EXPECT_LE(fit.sphericity, ls.stats.max_residual - ls.stats.min_residual + 1e-12);
    }
  }
}

// Random form (no known answer): no centre near the fit's gives a narrower zone.
TEST(MinZoneSphere, NoNearbyCentreBeatsItOnRandomForm) {
  std::mt19937_64 rng(21);
  std::normal_distribution<double> form(0.0, 0.003);
  Points3 p(3, 1500);
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double dr = form(rng);
    p.col(i) = Vec3(300, 200, -100) + (12.7 + dr) * test::RandomDirection(rng);
  }
  const auto fit = FitMinZoneSphere(p);
  EXPECT_TRUE(fit.stats.converged);
  std::normal_distribution<double> step(0.0, 2e-4);
  for (int k = 0; k < 3000; ++k) {
    const Vec3 c = fit.sphere.center + test::DrawVec3(step, rng);
    const Eigen::VectorXd r = (p.colwise() - c).colwise().norm();
    EXPECT_GE(r.maxCoeff() - r.minCoeff(), fit.sphericity - 1e-12);
  }
}

// ---- cylindricity ----

struct CylinderCase {
  const char* name;
  // Contact angles [deg] on the outer and inner cylinder at the top (z = +L) and bottom (-L).
  std::vector<double> outer_top, inner_top, outer_bottom, inner_bottom;
};

std::vector<CylinderCase> CylinderCases() {
  // Three lobes (a centreless-ground shaft) at both ends: 12 contacts. Two lobes turned by
  // 90 deg between the ends (a twisted oval): 8 contacts.
  return {{"three_lobes", {0, 120, 240}, {60, 180, 300}, {0, 120, 240}, {60, 180, 300}},
          {"twisted_oval", {0, 180}, {90, 270}, {90, 270}, {0, 180}}};
}

double CylinderZone(const Points3& p, const Vec3& point, const Vec3& axis) {
  const Eigen::VectorXd r = ((p.colwise() - point).colwise().cross(axis)).colwise().norm();
  return r.maxCoeff() - r.minCoeff();
}

TEST(MinZoneCylinder, ReferenceCylindersByConstruction) {
  for (const CylinderCase& c : CylinderCases()) {
    for (uint64_t seed = 1; seed <= 4; ++seed) {
      std::mt19937_64 rng(200 + seed);
      const Mat3 frame = RandomFrame(rng);
      const Vec3 origin = test::RandomDirection(rng) * 1000.0;
      const double radius = 4.0 + 8.0 * static_cast<double>(seed), half = 0.0015;  // 3 um
      const double length = 30.0;  // contacts at z = +-L
      const auto at = [&](double deg, double z, double r) {
        const double t = deg * M_PI / 180.0;
        return Vec3(origin + frame * Vec3(r * std::cos(t), r * std::sin(t), z));
      };
      std::vector<Vec3> pts;
      std::uniform_real_distribution<double> uni(-1.0, 1.0);
      for (int i = 0; i < 600; ++i) {
        const double dr = uni(rng);  // one draw per statement: tests/seeded_draw.h
        const double z = uni(rng);
        const double deg = 180.0 * uni(rng);
        pts.push_back(at(deg, length * z, radius + 0.9 * half * dr));
      }
      for (double deg : c.outer_top) pts.push_back(at(deg, length, radius + half));
      for (double deg : c.inner_top) pts.push_back(at(deg, length, radius - half));
      for (double deg : c.outer_bottom) pts.push_back(at(deg, -length, radius + half));
      for (double deg : c.inner_bottom) pts.push_back(at(deg, -length, radius - half));
      const Points3 p = ToColumns(pts);
      const auto fit = FitMinZoneCylinder(p);
      SCOPED_TRACE(std::string(c.name) + " seed " + std::to_string(seed));
      EXPECT_TRUE(fit.stats.converged);
      EXPECT_NEAR(fit.cylindricity, 2 * half, kZoneTolMm);
      EXPECT_LT(AngleUpToSign(fit.cylinder.axis, frame.col(2)), kAngleTolRad);
      EXPECT_LT((origin - fit.cylinder.point).cross(fit.cylinder.axis).norm(), kRefTolMm);
      EXPECT_NEAR(fit.outer_radius, radius + half, kZoneTolMm);
      EXPECT_NEAR(fit.inner_radius, radius - half, kZoneTolMm);
      const auto ls = FitCylinder(p);
      EXPECT_LE(fit.cylindricity, ls.stats.max_residual - ls.stats.min_residual + 1e-12);
    }
  }
}

// A bent, tapered shaft (no known answer): no nearby axis gives a narrower zone.
TEST(MinZoneCylinder, NoNearbyAxisBeatsItOnRandomForm) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.001);
  Points3 p(3, 2000);
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double z = 25.0 * uni(rng);
    const double t = M_PI * uni(rng);
    const double dr = noise(rng);
    const double r = 8.0 + 2e-4 * z + 3e-5 * z * z + dr;                  // taper and barrel
    p.col(i) = Vec3(r * std::cos(t) + 1e-5 * z * z, r * std::sin(t), z);  // and a bend
  }
  const auto fit = FitMinZoneCylinder(p);
  EXPECT_TRUE(fit.stats.converged);
  EXPECT_NEAR(CylinderZone(p, fit.cylinder.point, fit.cylinder.axis), fit.cylindricity, 1e-12);
  std::normal_distribution<double> shift(0.0, 2e-4), tilt(0.0, 1e-5);
  for (int k = 0; k < 3000; ++k) {
    const Vec3 point = fit.cylinder.point + test::DrawVec3(shift, rng);
    const Vec3 axis = (fit.cylinder.axis + test::DrawVec3(tilt, rng)).normalized();
    EXPECT_GE(CylinderZone(p, point, axis), fit.cylindricity - 1e-12);
  }
}

TEST(MinZoneCylinder, PointsOnOneCircleDoNotDetermineAnAxis) {
  Points3 p(3, 40);
  for (int i = 0; i < 40; ++i) p.col(i) = Vec3(std::cos(0.157 * i), std::sin(0.157 * i), 0.0);
  EXPECT_THROW(FitMinZoneCylinder(p), GeometryError);
}

// ---- in the plane ----

TEST(MinZoneLine2, ExactProfileWithAlternatingContacts) {
  std::mt19937_64 rng(41);
  const double angle = 0.7, half = 0.002;
  const Vec2 dir(std::cos(angle), std::sin(angle)), across(-dir.y(), dir.x());
  const Vec2 origin(-800.0, 600.0);
  Points2 p(2, 303);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int i = 0; i < 300; ++i) {
    const double t_across = uni(rng);
    const double t_along = uni(rng);
    p.col(i) = origin + dir * 60 * t_along + across * 0.9 * half * t_across;
  }
  p.col(300) = origin - dir * 60 - across * half;  // below, above, below
  p.col(301) = origin + dir * 5 + across * half;
  p.col(302) = origin + dir * 60 - across * half;
  const auto fit = FitMinZoneLine2(p);
  EXPECT_TRUE(fit.stats.converged);
  EXPECT_NEAR(fit.straightness, 2 * half, kZoneTolMm);
  EXPECT_LT(std::abs(fit.line.direction.x() * dir.y() - fit.line.direction.y() * dir.x()),
            kAngleTolRad);
  EXPECT_NEAR(std::abs(SignedDistance(fit.line, origin)), 0.0, kZoneTolMm);
  EXPECT_NEAR(fit.stats.max_residual - fit.stats.min_residual, 2 * half, kZoneTolMm);
}

TEST(MinZoneCircle2, ExactAlternatingContacts) {
  std::mt19937_64 rng(43);
  const double r = 15.0, half = 0.0025;
  const Vec2 centre(700.0, -650.0);
  Points2 p(2, 408);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int i = 0; i < 400; ++i) {
    const double dr = uni(rng);
    const double t = M_PI * uni(rng);
    p.col(i) = centre + (r + 0.9 * half * dr) * Vec2(std::cos(t), std::sin(t));
  }
  for (int k = 0; k < 8; ++k) {
    const double t = M_PI / 4 * k + 0.3;
    p.col(400 + k) = centre + (r + (k % 2 ? -half : half)) * Vec2(std::cos(t), std::sin(t));
  }
  const auto fit = FitMinZoneCircle2(p);
  EXPECT_TRUE(fit.stats.converged);
  EXPECT_NEAR(fit.roundness, 2 * half, kZoneTolMm);
  EXPECT_LT((fit.circle.center - centre).norm(), kZoneTolMm);
  EXPECT_NEAR(fit.outer_radius, r + half, kZoneTolMm);
  EXPECT_NEAR(fit.inner_radius, r - half, kZoneTolMm);
}

TEST(MinZone2, BadInputIsTyped) {
  Points2 two(2, 2);
  two << 0, 1, 0, 1;
  EXPECT_THROW(FitMinZoneCircle2(two), GeometryError);
  Points2 nan = Points2::Zero(2, 5);
  nan(0, 3) = NAN;
  EXPECT_THROW(FitMinZoneLine2(nan), GeometryError);
  EXPECT_THROW(FitMinZoneSphere(Points3::Zero(3, 4)), GeometryError);
}

}  // namespace
}  // namespace mlp::geometry
