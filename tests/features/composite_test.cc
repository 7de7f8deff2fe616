// Features of several surfaces (width, rectangle, step, angle, PCD, ellipse) and a surface patch
// against its nominal, on synthetic clouds with known truth: seeded noise of 2 um along the
// normals, neighbouring surfaces the segmentation must leave out.

#include "mlp/features/composite.h"

#include "mlp/features/surface.h"

#include "feature_points.h"
#include <gtest/gtest.h>

namespace mlp::features {
namespace {

using geometry::Vec3;
using test::CloudMaker;
using test::Dir;

constexpr double kNoiseMm = 0.002;
// Thousands of points per face at 2 um noise: sizes and positions to a fraction of a micrometre.
constexpr double kSizeTolMm = 0.0005;
constexpr double kAngleTolDeg = 0.001;       // 3.6 arcsec
constexpr double kEllipseTurnTolDeg = 0.01;  // an ellipse's major axis direction
constexpr double kCoverageTol = 0.03;        // the share of the nominal patch measured
constexpr double kRmsTolMm = 0.001;          // the surface's RMS against proud-and-noise

TEST(Width, SlotAndWeb) {
  // A slot 20.012 wide across X, centred at x = 0.005, 9 mm deep walls, its floor and the top
  // face beside it in the cloud.
  CloudMaker slot(1, kNoiseMm);
  const double w = 20.012, c = 0.005;
  for (double side : {1.0, -1.0})
    slot.Patch(Vec3(c + side * w / 2, -30, -10), Vec3::UnitY(), Vec3::UnitZ(), 60, 9, 3000);
  slot.Patch(Vec3(c - w / 2 + 1, -30, -12), Vec3::UnitX(), Vec3::UnitY(), w - 2, 60, 3000);
  slot.Patch(Vec3(c + w / 2 + 0.5, -30, 0), Vec3::UnitX(), Vec3::UnitY(), 10, 60, 3000);
  WidthNominal n;
  n.centre_mcs = Vec3(0, 0, -5), n.width_mm = 20.0, n.inside = true;
  const WidthMeasurement m = MeasureWidth(slot.Cloud(), n);
  EXPECT_NEAR(m.width_mm, w, kSizeTolMm);
  EXPECT_NEAR(m.centre_mcs.x(), c, kSizeTolMm);
  EXPECT_NEAR(m.parallelism_deg, 0.0, kAngleTolDeg);
  // The floor and the top face left out (3-sigma trimming takes the Gaussian tails).
  EXPECT_EQ(m.plus.points + m.plus.trimmed + m.minus.points + m.minus.trimmed, 6000);

  // A web 8.004 thick, the same faces seen from outside.
  CloudMaker web(2, kNoiseMm);
  for (double side : {1.0, -1.0})
    web.Patch(Vec3(side * 4.002, -30, -10), Vec3::UnitY(), Vec3::UnitZ(), 60, 9, 3000);
  n.width_mm = 8.0, n.inside = false;
  const WidthMeasurement wm = MeasureWidth(web.Cloud(), n);
  EXPECT_NEAR(wm.width_mm, 8.004, kSizeTolMm);
  EXPECT_NEAR(wm.centre_mcs.x(), 0.0, kSizeTolMm);

  n.centre_mcs.x() = 30;  // no faces there: the error says which face
  try {
    MeasureWidth(web.Cloud(), n);
    ADD_FAILURE() << "measured a width that is not there";
  } catch (const FeatureError& e) {
    EXPECT_NE(std::string(e.what()).find("width: the face at +direction"), std::string::npos);
  }
}

TEST(Rectangle, PocketTurnedAndOffset) {
  // An 80.010 x 50.004 pocket turned 0.2 deg, centred at (0.052, -0.003), walls z -10..-1 with
  // 3 mm corner regions not sampled.
  const double sx = 80.010, sy = 50.004, turn = 0.2;
  const Vec3 c(0.052, -0.003, 0), x = Dir(turn), y = Dir(turn + 90), z = Vec3::UnitZ();
  CloudMaker cloud(3, kNoiseMm);
  for (double s : {1.0, -1.0}) {
    cloud.Patch(c + s * sx / 2 * x - (sy / 2 - 3) * y - 10 * z, y, z, sy - 6, 9, 3000);
    cloud.Patch(c + s * sy / 2 * y - (sx / 2 - 3) * x - 10 * z, x, z, sx - 6, 9, 3000);
  }
  RectangleNominal n;
  n.centre_mcs = Vec3(0, 0, -5), n.size_x_mm = 80, n.size_y_mm = 50, n.within_mm = 20;
  const RectangleMeasurement m = MeasureRectangle(cloud.Cloud(), n);
  // The turn moves each face's crossing with the nominal line by a second-order amount:
  // (size/2)(1/cos(0.2 deg) - 1) = 0.25 um on the long side, inside the tolerance.
  EXPECT_NEAR(m.x.width_mm, sx, kSizeTolMm);
  EXPECT_NEAR(m.y.width_mm, sy, kSizeTolMm);
  EXPECT_NEAR(m.centre_mcs.x(), c.x(), kSizeTolMm);
  EXPECT_NEAR(m.centre_mcs.y(), c.y(), kSizeTolMm);
  EXPECT_NEAR(m.rotation_deg, turn, kAngleTolDeg);
}

TEST(Step, HeightBetweenTwoFaces) {
  CloudMaker cloud(4, kNoiseMm);
  cloud.Patch(Vec3(-30, -20, 0), Vec3::UnitX(), Vec3::UnitY(), 30, 40, 4000);
  cloud.Patch(Vec3(5, -20, 5.003), Vec3::UnitX(), Vec3::UnitY(), 30, 40, 4000);
  cloud.Patch(Vec3(0, -20, 0.5), Vec3::UnitZ(), Vec3::UnitY(), 4, 40, 1000);  // the wall
  StepNominal n;
  n.a.point_mcs = Vec3(-15, 0, 0), n.a.within_mm = 14;
  n.b.point_mcs = Vec3(20, 0, 5), n.b.within_mm = 14;
  const StepMeasurement m = MeasureStep(cloud.Cloud(), n);
  EXPECT_NEAR(m.height_mm, 5.003, kSizeTolMm);
  EXPECT_NEAR(m.parallelism_deg, 0.0, kAngleTolDeg * 10);  // 30 mm faces: 0.01 deg is 5 um
}

TEST(Angle, FaceAgainstADatumFaceAndAnAxis) {
  const double phi = 30.01 * M_PI / 180;
  const Vec3 v(0, std::cos(phi), std::sin(phi));  // up the chamfer
  CloudMaker cloud(5, kNoiseMm);
  cloud.Patch(Vec3(-10, 0, 0) - 5 * v, Vec3::UnitX(), v, 20, 10, 4000);
  cloud.Patch(Vec3(30, -15, -20), Vec3::UnitX(), Vec3::UnitY(), 30, 30, 4000);  // the datum
  AngleNominal n;
  n.face.point_mcs = Vec3::Zero();
  n.face.normal_mcs = Vec3(0, -std::sin(M_PI / 6), std::cos(M_PI / 6));
  n.face.within_mm = 9;
  n.datum_face = true;
  n.datum.point_mcs = Vec3(45, 0, -20);
  n.datum.within_mm = 14;
  const AngleMeasurement m = MeasureAngle(cloud.Cloud(), n);
  EXPECT_NEAR(m.angle_deg, 30.01, kAngleTolDeg * 2);  // 10 mm wide faces
  EXPECT_NEAR(m.skew_deg, 0.01, kAngleTolDeg * 2);
  n.datum_face = false;  // against machine Z
  EXPECT_NEAR(MeasureAngle(cloud.Cloud(), n).angle_deg, 30.01, kAngleTolDeg * 2);
}

TEST(Pcd, SixHolesOnABoltCircle) {
  const double pcd = 100.004, turn = 0.05;
  const Vec3 c(0.003, 0.002, 0);
  CloudMaker cloud(6, kNoiseMm);
  PcdNominal n;
  n.diameter_mm = 100;
  std::vector<Vec3> truth;
  for (int k = 0; k < 6; ++k) {
    const Vec3 at = c + pcd / 2 * Dir(60 * k + turn);
    truth.push_back(at);
    cloud.Wall(at.x(), at.y(), 5, -14, -1, 0, 360, 3000);
    BoreNominal hole;
    hole.top_centre_mcs = 50 * Dir(60 * k);
    hole.diameter_mm = 10, hole.depth_mm = 15, hole.band_mm = 0.2;
    n.holes.push_back(hole);
  }
  const PcdMeasurement m = MeasurePcd(cloud.Cloud(), n);
  EXPECT_NEAR(m.diameter_mm, pcd, kSizeTolMm);
  EXPECT_NEAR(m.centre_mcs.x(), c.x(), kSizeTolMm);
  EXPECT_NEAR(m.centre_mcs.y(), c.y(), kSizeTolMm);
  EXPECT_NEAR(m.rotation_deg, turn, kAngleTolDeg);
  for (int k = 0; k < 6; ++k)
    EXPECT_NEAR(
        m.true_position_mm[static_cast<size_t>(k)],
        2 * (truth[static_cast<size_t>(k)] - n.holes[static_cast<size_t>(k)].top_centre_mcs).norm(),
        2 * kSizeTolMm);
  n.holes.resize(2);
  EXPECT_THROW(MeasurePcd(cloud.Cloud(), n), FeatureError);
}

TEST(Ellipse, EllipticalBore) {
  const double a = 20.003, b = 12.502, turn = 10.0;
  const Vec3 c(0.004, -0.002, 0), u = Dir(turn), v = Dir(turn + 90);
  CloudMaker cloud(7, kNoiseMm);
  std::uniform_real_distribution<double> t(0, 2 * M_PI), z(-19, -1);
  for (int i = 0; i < 6000; ++i) {
    const double s = t(cloud.rng());
    const Vec3 normal = (b * std::cos(s) * u + a * std::sin(s) * v).normalized();
    cloud.Add(c + a * std::cos(s) * u + b * std::sin(s) * v + z(cloud.rng()) * Vec3::UnitZ(),
              normal);
  }
  cloud.Patch(Vec3(-40, -40, 0), Vec3::UnitX(), Vec3::UnitY(), 80, 80, 2000);  // top face
  EllipseNominal n;
  n.major_mm = 40, n.minor_mm = 25, n.depth_mm = 20;
  const EllipseMeasurement m = MeasureEllipse(cloud.Cloud(), n);
  EXPECT_NEAR(m.major_mm, 2 * a, 2 * kSizeTolMm);
  EXPECT_NEAR(m.minor_mm, 2 * b, 2 * kSizeTolMm);
  EXPECT_NEAR(m.top_centre_mcs.x(), c.x(), kSizeTolMm);
  EXPECT_NEAR(m.top_centre_mcs.y(), c.y(), kSizeTolMm);
  EXPECT_NEAR(m.rotation_deg, turn, kEllipseTurnTolDeg);
  EXPECT_NEAR(m.rms_mm, kNoiseMm, 0.2 * kNoiseMm);
  n.minor_mm = 45;  // minor over major
  EXPECT_THROW(MeasureEllipse(cloud.Cloud(), n), FeatureError);
}

// A convex cylindrical patch R 50 (axis Y, crown at z = 0), 40 deg by 30 mm, sampled every
// 0.5 mm as CAD would export it.
SurfaceNominal CylinderPatch() {
  constexpr double kR = 50, kStep = 0.5;
  std::ostringstream text;
  text << "# x y z i j k\n";
  for (double s = -17.5; s <= 17.5; s += kStep) {  // arc length
    const double phi = s / kR;
    for (double y = -15; y <= 15; y += kStep)
      text << kR * std::sin(phi) << " " << y << " " << kR * std::cos(phi) - kR << " "
           << std::sin(phi) << " 0 " << std::cos(phi) << "\n";
  }
  SurfaceNominal n = ParseVectorPoints(text.str());
  n.spacing_mm = kStep;
  return n;
}

TEST(Surface, PatchAgainstItsNominal) {
  const SurfaceNominal nominal = CylinderPatch();
  // The captures saw the half y >= 0, the surface 5 um proud everywhere, and a neighbouring
  // face 3 mm above.
  constexpr double kR = 50, kProudMm = 0.005;
  CloudMaker cloud(8, kNoiseMm);
  std::uniform_real_distribution<double> phi(-0.34, 0.34), y(0, 15);
  for (int i = 0; i < 20000; ++i) {
    const double p = phi(cloud.rng());
    const Vec3 normal(std::sin(p), 0, std::cos(p));
    cloud.Add(Vec3(0, y(cloud.rng()), -kR) + (kR + kProudMm) * normal, normal);
  }
  cloud.Patch(Vec3(-10, -10, 3), Vec3::UnitX(), Vec3::UnitY(), 20, 20, 2000);
  const SurfaceMeasurement m = MeasureSurface(cloud.Cloud(), nominal);
  // The tangent plane at the nearest nominal point lies above a convex surface by d^2 / (2 R):
  // on a 0.5 mm grid the mean of that is 0.4 um, the most 1.2 um.
  constexpr double kCurvatureBiasTolMm = 0.0008;
  EXPECT_NEAR(m.mean_mm, kProudMm, kCurvatureBiasTolMm);
  EXPECT_EQ(m.points, 20000);  // the face above left out
  EXPECT_NEAR(m.coverage, 0.5, kCoverageTol);
  EXPECT_GT(m.profile_mm, 2 * (kProudMm + 2 * kNoiseMm));
  EXPECT_LT(m.profile_mm, 2 * (kProudMm + 6 * kNoiseMm));
  EXPECT_NEAR(m.rms_mm, std::hypot(kProudMm, kNoiseMm), kRmsTolMm);
}

// A free-form patch (a quadric with cubic terms: every rigid motion changes it, 40 x 40 mm),
// its nominal as vector points; the measured patch has a 5 um bump and 1 um noise and was
// clamped off its place by 0.4 mrad and (15, -20, 10) um. Without a best fit the deviations
// hold the misplacement; with one, the motion is undone and the form (the bump) is left.
double Freeform(double x, double y) {
  return 0.002 * x * x - 0.001 * y * y + 2e-5 * x * x * x + 1.5e-5 * y * y * y + 1e-5 * x * x * y;
}
Vec3 FreeformNormal(double x, double y) {
  const double dx = 0.004 * x + 6e-5 * x * x + 2e-5 * x * y;
  const double dy = -0.002 * y + 4.5e-5 * y * y + 1e-5 * x * x;
  return Vec3(-dx, -dy, 1).normalized();
}

TEST(Surface, BestFitUndoesTheClampingAndLeavesTheForm) {
  std::ostringstream text;
  for (int i = -40; i <= 40; ++i)
    for (int k = -40; k <= 40; ++k) {
      const double x = 0.5 * i, y = 0.5 * k;
      const Vec3 nrm = FreeformNormal(x, y);
      text << x << ' ' << y << ' ' << Freeform(x, y) << ' ' << nrm.x() << ' ' << nrm.y() << ' '
           << nrm.z() << '\n';
    }
  SurfaceNominal nominal = ParseVectorPoints(text.str());
  nominal.spacing_mm = 0.5;
  constexpr double kBumpMm = 0.005, kNoise = 0.001;
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-19.5, 19.5);
  std::normal_distribution<double> noise(0, kNoise);
  const Eigen::Matrix3d clamp_r =
      Eigen::AngleAxisd(4e-4, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  const Vec3 clamp_t(0.015, -0.02, 0.01);
  geometry::Points3 truth(3, 15000), measured(3, 15000);
  for (Eigen::Index i = 0; i < truth.cols(); ++i) {
    const double x = u(rng);
    const double y = u(rng);
    const double e = noise(rng);
    const double bump = kBumpMm * std::exp(-(std::pow(x - 8, 2) + std::pow(y + 5, 2)) / 18);
    truth.col(i) = Vec3(x, y, Freeform(x, y)) + (bump + e) * FreeformNormal(x, y);
    measured.col(i) = clamp_r * truth.col(i) + clamp_t;
  }
  const SurfaceMeasurement placed = MeasureSurface(measured, nominal);
  nominal.best_fit = true;
  const SurfaceMeasurement form = MeasureSurface(measured, nominal);
  // The motion found brings each point back onto where it was before the clamping along the
  // surface's normal. Along the surface it may slide: a smooth patch barely tells a slide from
  // a tilt (here only its cubic terms do), which changes no deviation; that is printed.
  double worst_normal = 0, worst_along = 0;
  for (Eigen::Index i = 0; i < measured.cols(); ++i) {
    const auto& f = form.best_fit;
    const Eigen::Matrix3d r =
        Eigen::AngleAxisd(f.rotation_rad.norm(), f.rotation_rad.normalized()).toRotationMatrix();
    const Vec3 back = r * (measured.col(i) - f.about_mcs) + f.about_mcs + f.translation_mm;
    const Vec3 nrm = FreeformNormal(truth(0, i), truth(1, i));
    const double normal = (back - truth.col(i)).dot(nrm);
    worst_normal = std::max(worst_normal, std::abs(normal));
    worst_along = std::max(worst_along, (back - truth.col(i) - normal * nrm).norm());
  }
  std::printf(
      "surface: profile %.2f um as placed, %.2f um after the best fit (%d iterations); "
      "points back within %.2f um along the normal (%.1f um along the surface)\n",
      placed.profile_mm * 1e3, form.profile_mm * 1e3, form.best_fit.iterations, worst_normal * 1e3,
      worst_along * 1e3);
  EXPECT_TRUE(form.best_fit.converged);
  EXPECT_TRUE(form.best_fit.not_determined.empty());
  // The bump pulls the fit by a share of its volume over the patch: well under a micrometre.
  constexpr double kBackTolMm = 0.001;
  EXPECT_LT(worst_normal, kBackTolMm);
  EXPECT_GT(placed.profile_mm, 0.03);  // the misplacement dominates as placed
  EXPECT_GT(form.profile_mm, 2 * kBumpMm);
  EXPECT_LT(form.profile_mm, 2 * (kBumpMm + 5 * kNoise));
  EXPECT_EQ(form.points, 15000);
}

// A flat patch fixes only its normal's translation and its two tilts: the best fit says which
// three motions it leaves.
TEST(Surface, ABestFitOfAPlaneSaysWhatItCannotFix) {
  std::ostringstream text;
  for (int i = -20; i <= 20; ++i)
    for (int k = -20; k <= 20; ++k) text << 0.5 * i << ' ' << 0.5 * k << " 0 0 0 1\n";
  SurfaceNominal nominal = ParseVectorPoints(text.str());
  nominal.spacing_mm = 0.5;
  nominal.best_fit = true;
  geometry::Points3 p(3, 2000);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-9.5, 9.5);
  for (Eigen::Index i = 0; i < p.cols(); ++i) {
    const double x = u(rng);
    const double y = u(rng);
    p.col(i) = Vec3(x, y, 0.02 + 0.001 * x);  // 20 um high, tilted 1 mrad
  }
  const SurfaceMeasurement m = MeasureSurface(p, nominal);
  EXPECT_EQ(m.best_fit.not_determined.size(), 3u);
  EXPECT_LT(m.profile_mm, 1e-6);  // the height and the tilt are fixed and taken out
}

TEST(Surface, BadNominalsAreSaid) {
  EXPECT_THROW(ParseVectorPoints("1 2 3 0 0 1\n1 2 x 0 0 1\n"), FeatureError);
  EXPECT_THROW(ParseVectorPoints("1 2 3 0 0 1 7\n"), FeatureError);
  SurfaceNominal n = ParseVectorPoints("0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 2\n");
  EXPECT_THROW(MeasureSurface(geometry::Points3::Zero(3, 100), n), FeatureError);  // normal 2
  n.normals_mcs.col(2) = Vec3::UnitZ();
  EXPECT_THROW(MeasureSurface(geometry::Points3::Zero(3, 10), n), FeatureError);  // 10 points
}

}  // namespace
}  // namespace mlp::features
