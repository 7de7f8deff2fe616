// The trunnion check job on synthetic clouds (mlp::jobs, no service): sphere caps placed by
// known axes give the axes back; what cannot give a centre is refused, never fitted.

#include "mlp/jobs/kinematics.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

using geometry::Vec3;

constexpr double kRadiusMm = 12.7;
constexpr double kNoiseMm = 0.001;
constexpr double kPivotTolMm = 0.001;  // clean caps of 2,000 points: well under 1 um
const Vec3 kSphereOnTable(180, -40, -40);

calib::TrtPins Pins() {
  calib::TrtPins p;
  p.x_rot_point = 120, p.y_rot_point = -40, p.z_rot_point = -150;
  p.y_offset = 2.5, p.z_offset = 60;
  return p;
}

// The upper cap (within 50 deg of the top) of a sphere at `centre`, seeded noise along the normal.
geometry::Points3 Cap(const Vec3& centre, double radius, int n, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, kNoiseMm);
  geometry::Points3 p(3, n);
  for (int k = 0; k < n; ++k) {
    const double polar = std::acos(1 - u(*rng) * (1 - std::cos(50 * M_PI / 180)));
    const double az = 2 * M_PI * u(*rng);
    const Vec3 dir(std::sin(polar) * std::cos(az), std::sin(polar) * std::sin(az), std::cos(polar));
    p.col(k) = centre + (radius + noise(*rng)) * dir;
  }
  return p;
}

KinematicsInputs Plan(const calib::TrunnionAxes& truth, std::mt19937* rng) {
  KinematicsInputs in;
  in.sphere_radius_mm = kRadiusMm;
  in.pins = Pins();
  for (double a : {-30.0, 0.0, 30.0, 60.0}) {
    for (double c : {0.0, 120.0, 240.0}) {
      const Vec3 centre = calib::MachineFromTable(truth, a, c) * kSphereOnTable;
      char id[32];
      std::snprintf(id, sizeof id, "A%.0f C%.0f", a, c);
      in.captures.push_back({id, a, c, Cap(centre, kRadiusMm, 2000, rng)});
    }
  }
  return in;
}

TEST(KinematicsJob, SphereCapsGiveThePivotsBack) {
  std::mt19937 rng(54);
  calib::TrunnionAxes truth = calib::AxesOf(Pins());
  truth.c.point += Vec3(0.030, -0.020, 0);
  truth.a.point += Vec3(0, 0.025, -0.035);
  const KinematicsOutcome o = AssessKinematics(Plan(truth, &rng));
  ASSERT_TRUE(o.problems.empty()) << o.problems.front();
  ASSERT_TRUE(o.fit);
  EXPECT_FALSE(o.within);  // 20-45 um against the 10 um default
  const calib::TrtPins to = calib::PinsFor(*o.fit, Pins());
  EXPECT_NEAR(to.x_rot_point - 120, 0.030, kPivotTolMm);
  EXPECT_NEAR(to.y_rot_point + 40, -0.020, kPivotTolMm);
  EXPECT_NEAR(to.y_offset - 2.5, 0.045, kPivotTolMm);
  EXPECT_NEAR(to.z_offset - 60, -0.035, kPivotTolMm);
  for (const SphereSeen& s : o.spheres) EXPECT_LT(s.rms_mm, 2 * kNoiseMm) << s.id;
}

TEST(KinematicsJob, RightPinsAreWithinTheLimits) {
  std::mt19937 rng(55);
  const KinematicsOutcome o = AssessKinematics(Plan(calib::AxesOf(Pins()), &rng));
  ASSERT_TRUE(o.fit);
  EXPECT_TRUE(o.within);
}

TEST(KinematicsJob, ACaptureThatIsNotTheSphereIsRefusedNotFitted) {
  std::mt19937 rng(56);
  KinematicsInputs in = Plan(calib::AxesOf(Pins()), &rng);
  in.captures[4].points_machine = Cap(Vec3(90, 12, -40), 10.0, 2000, &rng);  // another ball
  in.captures[7].points_machine = in.captures[7].points_machine.leftCols(50).eval();  // no alias
  const KinematicsOutcome o = AssessKinematics(in);
  EXPECT_FALSE(o.fit);
  ASSERT_EQ(o.problems.size(), 2u);
  EXPECT_NE(o.problems[0].find("not the reference"), std::string::npos) << o.problems[0];
  EXPECT_NE(o.problems[1].find("holds 50 points"), std::string::npos) << o.problems[1];
}

TEST(KinematicsJob, PositionsThatCannotDetermineTheAxesAreRefused) {
  std::mt19937 rng(57);
  KinematicsInputs in = Plan(calib::AxesOf(Pins()), &rng);
  in.captures.resize(6);  // A at two positions only
  const KinematicsOutcome o = AssessKinematics(in);
  EXPECT_FALSE(o.fit);
  ASSERT_EQ(o.problems.size(), 1u);
}

TEST(KinematicsJob, ACalibrationMovesOnlyWhatTheCentresSay) {
  std::mt19937 rng(58);
  calib::TrunnionAxes truth = calib::AxesOf(Pins());
  truth.c.point += Vec3(0.030, 0, 0);  // x-rot-point only
  KinematicsInputs in = Plan(truth, &rng);
  in.calibrate = true;
  const KinematicsOutcome o = AssessKinematics(in);
  ASSERT_TRUE(o.new_pins);
  EXPECT_NEAR(o.new_pins->x_rot_point, 120.030, kPivotTolMm);
  for (const PinChange& c : o.changes) EXPECT_EQ(c.changed, c.name == "x-rot-point") << c.name;
  EXPECT_EQ(o.new_pins->y_rot_point, -40.0);  // within the null band: kept exactly
  EXPECT_EQ(o.new_pins->z_offset, 60.0);
  // Beyond the machine's largest change: refused whole, nothing to write.
  in.max_change_mm = 0.020;
  const KinematicsOutcome too_far = AssessKinematics(in);
  EXPECT_FALSE(too_far.new_pins);
  ASSERT_EQ(too_far.problems.size(), 1u);
  EXPECT_NE(too_far.problems[0].find("x-rot-point"), std::string::npos) << too_far.problems[0];
}

}  // namespace
}  // namespace mlp::jobs
