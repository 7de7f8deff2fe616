// Bad input gets a typed error and never a NaN: every fit, every kind of bad cloud.

#include "mlp/geometry/chebyshev.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <random>

#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

using Fit3 = std::function<void(const Points3&)>;

std::vector<std::pair<std::string, Fit3>> AllFits() {
  return {{"line", [](const Points3& p) { FitLine3(p); }},
          {"plane", [](const Points3& p) { FitPlane(p); }},
          {"circle", [](const Points3& p) { FitCircle3(p); }},
          {"sphere", [](const Points3& p) { FitSphere(p); }},
          {"cylinder", [](const Points3& p) { FitCylinder(p); }},
          {"cone", [](const Points3& p) { FitCone(p); }},
          {"ellipse", [](const Points3& p) { FitEllipse3(p); }},
          {"minzone plane", [](const Points3& p) { FitMinZonePlane(p); }},
          {"minzone circle", [](const Points3& p) { FitMinZoneCircle(p); }},
          {"mcc", [](const Points3& p) { FitMinCircumscribedCircle(p); }},
          {"robust plane", [](const Points3& p) { FitPlaneRobust(p); }},
          {"robust sphere", [](const Points3& p) { FitSphereRobust(p); }}};
}

ErrorCode CodeOf(const Fit3& fit, const Points3& p) {
  try {
    fit(p);
  } catch (const GeometryError& e) {
    EXPECT_FALSE(std::string(e.what()).empty());
    return e.code();
  }
  ADD_FAILURE() << "no error";
  return ErrorCode::kInvalidArgument;
}

TEST(BadInput, EmptyAndTooFewPoints) {
  for (const auto& [name, fit] : AllFits()) {
    EXPECT_EQ(CodeOf(fit, Points3(3, 0)), ErrorCode::kTooFewPoints) << name;
    EXPECT_EQ(CodeOf(fit, Points3::Random(3, 1)), ErrorCode::kTooFewPoints) << name;
  }
}

TEST(BadInput, NanAndInfinity) {
  for (double bad : {NAN, INFINITY, -INFINITY}) {
    Points3 p = Points3::Random(3, 50);
    p(1, 17) = bad;
    for (const auto& [name, fit] : AllFits())
      EXPECT_EQ(CodeOf(fit, p), ErrorCode::kNonFinite) << name;
  }
}

TEST(BadInput, CoincidentPoints) {
  const Points3 p = Vec3(1000, 2, 3).replicate(1, 40);
  for (const auto& [name, fit] : AllFits()) {
    const ErrorCode code = CodeOf(fit, p);
    EXPECT_TRUE(code == ErrorCode::kDegenerate) << name << " " << ToString(code);
  }
}

TEST(BadInput, CollinearPointsDoNotMakeSurfaces) {
  Points3 p(3, 40);
  for (int i = 0; i < 40; ++i) p.col(i) = Vec3(1, 2, 3) + i * Vec3(0.3, -0.2, 0.9);
  for (const auto& [name, fit] : AllFits()) {
    if (name == "line") continue;  // a line is exactly what they make
    EXPECT_EQ(CodeOf(fit, p), ErrorCode::kDegenerate) << name;
  }
}

TEST(BadInput, CoplanarPointsDoNotDetermineSphereCylinderCone) {
  Points3 p(3, 60);
  for (int i = 0; i < 60; ++i) {
    const double t = 2 * M_PI * i / 60;
    p.col(i) = Vec3(10 * std::cos(t), 10 * std::sin(t), 5.0);  // one circle: many spheres fit
  }
  EXPECT_EQ(CodeOf(AllFits()[3].second, p), ErrorCode::kDegenerate);
  EXPECT_EQ(CodeOf(AllFits()[4].second, p), ErrorCode::kDegenerate);
}

// An iteration limit reached is an expected numerical outcome: by default a typed error; with
// require_convergence off, the last iterate as a result that says so (docs/DEVELOPING.md).
TEST(NotConverged, IsAnErrorByDefaultOrAResultThatSaysSo) {
  constexpr int kPoints = 400;
  Points3 cap(3, kPoints), wall(3, kPoints), ring(3, kPoints);
  std::srand(7);  // Eigen's Random draws from rand(): seeded
  const Points3 noise = 0.01 * Points3::Random(3, kPoints);
  for (int i = 0; i < kPoints; ++i) {
    const double a = 0.02 * i, b = 0.4 * std::sin(0.37 * i);  // a 60 deg cap, a 460 deg wall
    cap.col(i) =
        Vec3(25 * std::sin(b) * std::cos(a), 25 * std::sin(b) * std::sin(a), 25 * std::cos(b)) +
        noise.col(i);
    wall.col(i) = Vec3(6 * std::cos(a), 6 * std::sin(a), 0.05 * i) + noise.col(i);
    ring.col(i) = Vec3(6 * std::cos(a), 6 * std::sin(a), 0.0) + noise.col(i);
  }
  FitOptions one;
  one.max_iterations = 1;
  FitOptions estimate = one;
  estimate.require_convergence = false;
  const auto check = [&](const char* name, auto fit, const Points3& p) {
    SCOPED_TRACE(name);
    EXPECT_EQ(CodeOf([&](const Points3& q) { fit(q, one); }, p), ErrorCode::kNotConverged);
    const auto last = fit(p, estimate);
    EXPECT_FALSE(last.stats.converged);
    const auto converged = fit(p, FitOptions{});
    EXPECT_TRUE(converged.stats.converged);
    // The estimate is finite and no better than the stationary point (least squares).
    EXPECT_TRUE(std::isfinite(last.stats.rms));
    EXPECT_GE(last.stats.rms, converged.stats.rms * (1 - 1e-12));
  };
  check(
      "sphere", [](const Points3& p, const FitOptions& o) { return FitSphere(p, o); }, cap);
  check(
      "circle", [](const Points3& p, const FitOptions& o) { return FitCircle3(p, o); }, ring);
  // The cylinder's own start is near exact here: started 10 deg off and 1 mm wide instead.
  Cylinder off;
  off.point = Vec3(0.5, 0, 0);
  off.axis = Vec3(std::sin(0.17), 0, std::cos(0.17));
  off.radius = 7;
  check(
      "cylinder", [&](const Points3& p, const FitOptions& o) { return FitCylinder(p, o, off); },
      wall);
}

// The robust fits: the least-squares fit of the inliers follows RobustOptions::least_squares,
// and the trimming says whether the inlier set settled.
TEST(NotConverged, RobustFitsSayItOfTheirInliersFitAndOfTheTrimming) {
  constexpr int kPoints = 400;
  std::srand(11);  // Eigen's Random draws from rand(): seeded
  const Points3 noise = 0.01 * Points3::Random(3, kPoints);
  Points3 cap(3, kPoints);
  for (int i = 0; i < kPoints; ++i) {
    const double a = 0.02 * i, b = 0.4 * std::sin(0.37 * i);
    cap.col(i) =
        Vec3(25 * std::sin(b) * std::cos(a), 25 * std::sin(b) * std::sin(a), 25 * std::cos(b)) +
        noise.col(i);
    if (i % 10 == 0) cap.col(i) += Vec3(0, 0, 3);  // spatter: 10 % off the sphere
  }
  const auto settled = FitSphereRobust(cap);
  EXPECT_TRUE(settled.inliers_settled);
  EXPECT_TRUE(settled.Converged());
  RobustOptions one;
  one.least_squares.max_iterations = 1;
  EXPECT_EQ(CodeOf([&](const Points3& q) { FitSphereRobust(q, one); }, cap),
            ErrorCode::kNotConverged);
  one.least_squares.require_convergence = false;
  const auto estimate = FitSphereRobust(cap, one);
  EXPECT_FALSE(estimate.fit.stats.converged);
  EXPECT_FALSE(estimate.Converged());
  EXPECT_TRUE(std::isfinite(estimate.fit.stats.rms));
  RobustOptions short_trim;
  short_trim.max_refinements = 1;  // one trimming pass cannot show that the set is stable
  const auto trimmed_once = FitSphereRobust(cap, short_trim);
  EXPECT_FALSE(trimmed_once.inliers_settled);
  EXPECT_TRUE(trimmed_once.fit.stats.converged);
  EXPECT_EQ(trimmed_once.fit.stats.n, static_cast<int>(trimmed_once.inliers.size()));
}

TEST(BadInput, BadOptionsAreRejected) {
  FitOptions o;
  o.max_iterations = 0;
  EXPECT_THROW(FitSphere(Points3::Random(3, 10), o), GeometryError);
  RobustOptions r;
  r.confidence = 1.5;
  EXPECT_THROW(FitPlaneRobust(Points3::Random(3, 10), r), GeometryError);
  r = RobustOptions{};
  r.inlier_threshold_mm = NAN;
  EXPECT_THROW(FitPlaneRobust(Points3::Random(3, 10), r), GeometryError);
  r = RobustOptions{};
  r.least_squares.max_iterations = 0;
  EXPECT_THROW(FitPlaneRobust(Points3::Random(3, 10), r), GeometryError);
}

// A cone ends at its tip. Points on both nappes (an hourglass, or a window drawn past the tip)
// are no cone feature: the least squares fits neither nappe (issue 49's seed 8500: 230 um RMS
// at 2 um noise, half angle 61 sigma off) and is refused, naming the points beyond the apex. A
// cone measured right up to its tip is not: the tip holds few points, and noise there reaches
// only a little beyond it.
TEST(BadInput, PointsOnBothNappesAreNoCone) {
  constexpr double kNoiseMm = 0.002, kHalfAngleRad = 0.9;
  constexpr double kHalfAngleTolRad = 1e-3;  // 2 um noise over 10 mm of generatrix: ~1e-4
  std::mt19937_64 rng(49);
  std::normal_distribution<double> noise(0.0, kNoiseMm);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const auto cone_points = [&](double z_from_apex_min, double z_max) {
    Points3 p(3, 4000);
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
      const double z = z_from_apex_min + (z_max - z_from_apex_min) * uni(rng);
      const double phi = 2 * M_PI * uni(rng), r = z * std::tan(kHalfAngleRad);  // r < 0: below
      p.col(i) =
          Vec3(r * std::cos(phi), r * std::sin(phi), z) + Vec3(noise(rng), noise(rng), noise(rng));
    }
    return p;
  };
  for (const double below_mm : {1.0, 3.0}) {
    const Points3 hourglass = cone_points(-below_mm, 6.0);
    try {
      const auto fit = FitCone(hourglass);
      ADD_FAILURE() << below_mm << " mm below the tip: fitted, RMS " << fit.stats.rms * 1e3
                    << " um, half angle " << fit.shape.half_angle;
    } catch (const GeometryError& e) {
      EXPECT_EQ(e.code(), ErrorCode::kDegenerate) << e.what();
      const std::string what = e.what();
      EXPECT_TRUE(what.find("beyond the fitted apex") != std::string::npos ||
                  what.find("not on one cone") != std::string::npos)
          << what;
    }
  }
  const auto to_the_tip = FitCone(cone_points(0.0, 10.0));
  EXPECT_NEAR(to_the_tip.shape.half_angle, kHalfAngleRad, kHalfAngleTolRad);
  EXPECT_LT(to_the_tip.shape.Apex().norm(), 0.01);  // mm
}

}  // namespace
}  // namespace mlp::geometry
