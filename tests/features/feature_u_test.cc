// Issue 49, "uncertainty you can trust" for the features built on faces and the ellipse: each
// feature measured 200 times on freshly drawn points (its own generator here: the points are
// written from the shape's equations with Gaussian noise, nothing of the method's), the
// standard deviation of the 200 values against the mean u the feature reported. Within 20 %
// (GUM S1's check of a propagated uncertainty by a Monte Carlo; 200 repeats estimate a
// standard deviation to about 5 %). Windows are partial on purpose: a face judged far from
// the points seen, a step whose faces do not overlap, an ellipse's 150-degree arc.

#include "mlp/features/composite.h"
#include "mlp/features/feature.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::features {
namespace {

using geometry::Points3;
using geometry::Vec3;

constexpr int kRepeats = 200;
constexpr double kNoiseMm = 0.002;   // 2 um, the issue's
constexpr double kAgreement = 0.20;  // reported u against the repeats' scatter
constexpr unsigned kSeed = 4901;     // fixed before the check was written
constexpr int kPointsPerFace = 400;

unsigned Seed() {
  const char* s = std::getenv("MLP_U_SEED");
  return s != nullptr ? static_cast<unsigned>(std::strtoul(s, nullptr, 10)) : kSeed;
}

struct Draw {
  std::mt19937 gen{Seed()};
  std::normal_distribution<double> noise{0.0, kNoiseMm};
  std::uniform_real_distribution<double> unit{0.0, 1.0};
};

// Points of the face through `origin` spanned by `a` and `b` (rectangle of the given sides),
// pushed along `normal` by Gaussian noise.
void AddFace(Draw* d,
             const Vec3& origin,
             const Vec3& a,
             double a_mm,
             const Vec3& b,
             double b_mm,
             std::vector<Vec3>* out) {
  const Vec3 normal = a.cross(b).normalized();
  for (int i = 0; i < kPointsPerFace; ++i)
    out->push_back(origin + (d->unit(d->gen) * a_mm) * a + (d->unit(d->gen) * b_mm) * b +
                   d->noise(d->gen) * normal);
}

Points3 Cloud(const std::vector<Vec3>& p) {
  Points3 c(3, static_cast<Eigen::Index>(p.size()));
  for (size_t i = 0; i < p.size(); ++i) c.col(static_cast<Eigen::Index>(i)) = p[i];
  return c;
}

struct Agreement {
  double scatter = 0.0, mean_u = 0.0;
};

// Runs `measure` kRepeats times: it returns {value, reported u}.
Agreement Repeat(const std::function<std::pair<double, double>(Draw*)>& measure) {
  Draw d;
  std::vector<double> values;
  double sum_u = 0.0;
  for (int k = 0; k < kRepeats; ++k) {
    const auto [value, u] = measure(&d);
    values.push_back(value);
    sum_u += u;
  }
  double mean = 0.0;
  for (double v : values) mean += v / kRepeats;
  double ss = 0.0;
  for (double v : values) ss += (v - mean) * (v - mean);
  return {std::sqrt(ss / (kRepeats - 1)), sum_u / kRepeats};
}

void ExpectAgrees(const Agreement& a, const char* what) {
  std::printf("%-40s scatter %.4g, mean reported u %.4g (ratio %.3f)\n", what, a.scatter, a.mean_u,
              a.mean_u / a.scatter);
  EXPECT_GT(a.scatter, 0.0) << what;
  EXPECT_NEAR(a.mean_u / a.scatter, 1.0, kAgreement) << what;
}

// A 20 x 20 mm window of the face z = 0, its height judged 40 mm away: the tilts' lever.
TEST(FeatureU, AFacesHeightAwayFromItsWindow) {
  ExpectAgrees(Repeat([](Draw* d) {
                 std::vector<Vec3> p;
                 AddFace(d, Vec3(0, 0, 0), Vec3::UnitX(), 20, Vec3::UnitY(), 20, &p);
                 PlaneNominal n;
                 n.point_mcs = Vec3(50, 10, 0);
                 n.band_mm = 0.05;
                 const PlaneMeasurement m = MeasurePlane(Cloud(p), n);
                 return std::pair{m.height_mm, m.height_u_mm};
               }),
               "face height 40 mm off its window [mm]");
}

// A slot 16 wide: two wall windows 10 x 5 mm.
TEST(FeatureU, AWidthBetweenTwoWindows) {
  ExpectAgrees(Repeat([](Draw* d) {
                 std::vector<Vec3> p;
                 AddFace(d, Vec3(8, -5, -6), Vec3::UnitY(), 10, Vec3::UnitZ(), 5, &p);
                 AddFace(d, Vec3(-8, -5, -6), Vec3::UnitY(), 10, Vec3::UnitZ(), 5, &p);
                 WidthNominal n;
                 n.centre_mcs = Vec3(0, 0, -3.5);
                 n.width_mm = 16;
                 n.band_mm = 0.05;
                 const WidthMeasurement m = MeasureWidth(Cloud(p), n);
                 return std::pair{m.width_mm, m.width_u_mm};
               }),
               "slot width [mm]");
}

// A shoulder 10 high whose upper face is seen 30 mm beside the lower face's window.
TEST(FeatureU, AStepBetweenFacesThatDoNotOverlap) {
  ExpectAgrees(Repeat([](Draw* d) {
                 std::vector<Vec3> p;
                 AddFace(d, Vec3(0, 0, 0), Vec3::UnitX(), 10, Vec3::UnitY(), 10, &p);
                 AddFace(d, Vec3(40, 0, 10), Vec3::UnitX(), 10, Vec3::UnitY(), 10, &p);
                 StepNominal n;
                 n.a.point_mcs = Vec3(5, 5, 0), n.a.band_mm = 0.05, n.a.within_mm = 8;
                 n.b.point_mcs = Vec3(45, 5, 10), n.b.band_mm = 0.05, n.b.within_mm = 8;
                 const StepMeasurement m = MeasureStep(Cloud(p), n);
                 return std::pair{m.height_mm, m.height_u_mm};
               }),
               "step height, faces 30 mm apart [mm]");
}

// A 30 degree chamfer (5 x 5 mm window) against the machine's Z, and against a datum face.
TEST(FeatureU, AnAngleAgainstAnAxisAndAgainstAFace) {
  const double t = 30.0 * M_PI / 180.0;
  const Vec3 along(std::cos(t), 0, std::sin(t));  // the chamfer rises along +x
  const Vec3 normal = Vec3::UnitY().cross(along);
  for (const bool datum_face : {false, true}) {
    ExpectAgrees(Repeat([&](Draw* d) {
                   std::vector<Vec3> p;
                   AddFace(d, Vec3(0, 0, 0), along, 5, Vec3::UnitY(), 5, &p);
                   if (datum_face)
                     AddFace(d, Vec3(-30, 0, -10), Vec3::UnitX(), 20, Vec3::UnitY(), 20, &p);
                   AngleNominal n;
                   n.face.point_mcs = 2.5 * along + Vec3(0, 2.5, 0);
                   n.face.normal_mcs = normal;
                   n.face.band_mm = 0.05, n.face.within_mm = 4;
                   n.datum_face = datum_face;
                   n.datum.point_mcs = Vec3(-20, 10, -10);
                   n.datum.normal_mcs = Vec3::UnitZ();
                   n.datum.band_mm = 0.05, n.datum.within_mm = 9;
                   const AngleMeasurement m = MeasureAngle(Cloud(p), n);
                   return std::pair{m.angle_deg, m.angle_u_deg};
                 }),
                 datum_face ? "chamfer angle to a datum face [deg]" : "chamfer angle to Z [deg]");
  }
}

// An elliptical bore 40 x 24 seen over 150 degrees of its wall (a window on one side).
TEST(FeatureU, AnEllipsesAxesFromAPartialWall) {
  for (const bool major : {true, false}) {
    ExpectAgrees(
        Repeat([&](Draw* d) {
          std::vector<Vec3> p;
          const double a = 20, b = 12;
          for (int i = 0; i < 600; ++i) {
            const double phi = (-75.0 + 150.0 * d->unit(d->gen)) * M_PI / 180.0;
            const double z = -2.0 - 6.0 * d->unit(d->gen);
            // The wall's outward normal in the section, for the noise.
            const Vec3 on(a * std::cos(phi), b * std::sin(phi), z);
            const Vec3 out = Vec3(std::cos(phi) / a, std::sin(phi) / b, 0).normalized();
            p.push_back(on + d->noise(d->gen) * out);
          }
          EllipseNominal n;
          n.major_mm = 40, n.minor_mm = 24, n.depth_mm = 10;
          n.band_mm = 0.05;
          const EllipseMeasurement m = MeasureEllipse(Cloud(p), n);
          return major ? std::pair{m.major_mm, m.major_u_mm} : std::pair{m.minor_mm, m.minor_u_mm};
        }),
        major ? "ellipse major, 150 deg of wall [mm]" : "ellipse minor, 150 deg of wall [mm]");
  }
}

}  // namespace
}  // namespace mlp::features
