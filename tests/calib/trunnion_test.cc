// A trunnion's rotary axes from a sphere on its C table (issue 54, the estimation only): the
// table's motion is LinuxCNC's xyzac-trt-kins where the axes are its own; the fit finds pivot
// errors of tens of micrometres and a squareness of 0.01 deg from centres with 1 um of noise,
// its stated uncertainties cover the errors it makes, it changes nothing where the pins are
// right, and it refuses plans and centres that cannot determine the lines.
// World: synthetic centres (the truth is the generator's lines, no probe in between), so these
// figures say what the method and the plan can determine, not what a probe measures.

#include "mlp/calib/trunnion.h"

#include "mlp/calib/trunnion_hal.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kPinTolMm = 0.002;       // issue 54: each pivot within 2 um
constexpr double kAngleTolDeg = 0.002;    // and each squareness within 0.002 deg
constexpr double kCentreNoiseMm = 0.001;  // a fitted sphere centre's scatter per axis
constexpr double kCoverSigmas = 4.0;      // an error beyond 4 stated sigmas: the sigma lies

// The sample configuration's pins (xyzac-trt.ini's order of size), the tool offset a probe's.
TrtPins Controller() {
  TrtPins p;
  p.x_rot_point = 120.0, p.y_rot_point = -40.0, p.z_rot_point = -150.0;
  p.y_offset = 2.5, p.z_offset = 60.0, p.tool_offset = 110.0;
  return p;
}

// xyzac-trt-kins' forward map (its source, src/emc/kinematics/trtfuncs.c): the tool's position
// in the table's coordinates from the joints, as LinuxCNC computes it with TCP on.
Vec3 LinuxCncTableCoordinates(const TrtPins& k, const Vec3& j, double a_deg, double c_deg) {
  const double a = a_deg * kDeg, c = c_deg * kDeg, dy = k.y_offset;
  const double dz = k.z_offset + k.tool_offset;
  const double x = j.x() - k.x_rot_point, y = j.y() - dy - k.y_rot_point;
  const double z = j.z() - dz - k.z_rot_point;
  return {std::cos(c) * x + std::sin(c) * std::cos(a) * y + std::sin(c) * std::sin(a) * z +
              std::sin(c) * dy + k.x_rot_point,
          -std::sin(c) * x + std::cos(c) * std::cos(a) * y + std::cos(c) * std::sin(a) * z +
              std::cos(c) * dy + k.y_rot_point,
          -std::sin(a) * y + std::cos(a) * z + dz + k.z_rot_point};
}

TEST(Trunnion, TheTablesMotionIsLinuxCncsWhereTheAxesAreItsOwn) {
  const TrtPins pins = Controller();
  const Vec3 on_table(135.0, -22.0, -95.0);
  for (double a : {-30.0, 0.0, 17.0, 90.0}) {
    for (double c : {0.0, 45.0, 200.0}) {
      const Vec3 machine = MachineFromTable(AxesOf(pins), a, c) * on_table;
      EXPECT_LT((LinuxCncTableCoordinates(pins, machine, a, c) - on_table).norm(), 1e-9)
          << "A " << a << " C " << c;
    }
  }
}

// The true trunnion: the pins' lines moved by tens of micrometres, A turned 0.01 deg about Z and
// C 0.008 deg about Y (the squareness no pin holds) and 0.006 deg about X (an A zero off).
TrunnionAxes TrueAxes() {
  TrunnionAxes axes = AxesOf(Controller());
  axes.c.point += Vec3(0.031, -0.024, 0.0);
  axes.a.point += Vec3(0.0, 0.018, -0.043);
  axes.a.direction = Eigen::AngleAxisd(0.010 * kDeg, Vec3::UnitZ()) * axes.a.direction;
  axes.c.direction = Eigen::AngleAxisd(0.008 * kDeg, Vec3::UnitY()) *
                     Eigen::AngleAxisd(0.006 * kDeg, Vec3::UnitX()) * axes.c.direction;
  return axes;
}

// Where two lines come closest, solved as the 2 x 2 normal equations of |pa + s ua - pc - t uc|.
void FeetOfCommonPerpendicular(const TrunnionAxes& l, Vec3* on_a, Vec3* on_c) {
  Eigen::Matrix2d m;
  m << l.a.direction.dot(l.a.direction), -l.a.direction.dot(l.c.direction),
      l.a.direction.dot(l.c.direction), -l.c.direction.dot(l.c.direction);
  const Vec3 w = l.c.point - l.a.point;
  const Eigen::Vector2d st =
      m.inverse() * Eigen::Vector2d(l.a.direction.dot(w), l.c.direction.dot(w));
  *on_a = l.a.point + st[0] * l.a.direction;
  *on_c = l.c.point + st[1] * l.c.direction;
}

// The sphere 60 mm off the C axis on the table, A at five tilts, C at four turns each.
std::vector<TrunnionObservation> Plan(const TrunnionAxes& truth, double noise_mm, unsigned seed) {
  const Vec3 sphere(120.0 + 60.0, -40.0 + 10.0, -60.0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, noise_mm);
  std::vector<TrunnionObservation> out;
  for (double a : {-30.0, 0.0, 30.0, 60.0, 90.0}) {
    for (double c : {0.0, 90.0, 180.0, 270.0}) {
      TrunnionObservation o{a, c, MachineFromTable(truth, a, c) * sphere};
      o.centre_machine_mm += Vec3(n(rng), n(rng), n(rng));
      out.push_back(o);
    }
  }
  return out;
}

TEST(Trunnion, FindsPivotsAndSquarenessWithinTheIssuesLimitsAndSaysHowWell) {
  const TrunnionAxes truth = TrueAxes();
  const TrtPins pins = Controller();
  // What the true lines mean in the pins' four sums (the common perpendicular's feet).
  TrunnionFit exact = FitTrunnion(Plan(truth, 0.0, 1), AxesOf(pins));
  ASSERT_LT(exact.residual_rms_mm, 1e-7);
  int covered = 0, checks = 0;
  for (unsigned seed = 11; seed < 21; ++seed) {
    const TrunnionFit fit = FitTrunnion(Plan(truth, kCentreNoiseMm, seed), AxesOf(pins));
    const auto check = [&](double found, double want, double u, double tol, const char* what) {
      EXPECT_NEAR(found, want, tol) << what << " seed " << seed;
      covered += std::abs(found - want) <= kCoverSigmas * u;
      ++checks;
    };
    check(fit.c_x_mm, exact.c_x_mm, fit.c_x_u_mm, kPinTolMm, "C x");
    check(fit.c_y_mm, exact.c_y_mm, fit.c_y_u_mm, kPinTolMm, "C y");
    check(fit.a_y_mm, exact.a_y_mm, fit.a_y_u_mm, kPinTolMm, "A y");
    check(fit.a_z_mm, exact.a_z_mm, fit.a_z_u_mm, kPinTolMm, "A z");
    check(fit.a_about_z_deg, 0.010, fit.a_about_z_u_deg, kAngleTolDeg, "A about Z");
    check(fit.c_about_y_deg, 0.008, fit.c_about_y_u_deg, kAngleTolDeg, "C about Y");
    check(fit.c_about_x_deg, 0.006, fit.c_about_x_u_deg, kAngleTolDeg, "C about X");
    EXPECT_NEAR(fit.residual_rms_mm, kCentreNoiseMm * std::sqrt(3.0 * (60 - 11) / 60.0),
                0.5 * kCentreNoiseMm);
  }
  EXPECT_GE(covered, checks - 1) << "errors beyond 4 of the fit's own sigmas";
  // The pins that hold the true lines, what calibrate would write: LinuxCNC's lines meet the
  // true ones where the true lines come closest (a tilted C's point moves with the height).
  Vec3 on_a, on_c;
  FeetOfCommonPerpendicular(truth, &on_a, &on_c);
  const TrtPins to = PinsFor(exact, pins);
  EXPECT_NEAR(to.x_rot_point, on_c.x(), 1e-6);
  EXPECT_NEAR(to.y_rot_point, on_c.y(), 1e-6);
  EXPECT_NEAR(to.y_offset, on_a.y() - on_c.y(), 1e-6);
  EXPECT_NEAR(to.z_offset + pins.z_rot_point + pins.tool_offset, on_a.z(), 1e-6);
  // 31 um moved, and 2.8 um more from C's 0.008 deg over the 20 mm between z = 0 and A.
  EXPECT_NE(Describe(exact, pins).find("x-rot-point: 33.8 um off"), std::string::npos)
      << Describe(exact, pins);
}

TEST(Trunnion, RightPinsAreLeftAsTheyAre) {
  const TrtPins pins = Controller();
  const TrunnionFit fit = FitTrunnion(Plan(AxesOf(pins), kCentreNoiseMm, 5), AxesOf(pins));
  const TrtPins to = PinsFor(fit, pins);
  EXPECT_NEAR(to.x_rot_point, pins.x_rot_point, kPinTolMm);
  EXPECT_NEAR(to.y_rot_point, pins.y_rot_point, kPinTolMm);
  EXPECT_NEAR(to.y_offset, pins.y_offset, kPinTolMm);
  EXPECT_NEAR(to.z_offset, pins.z_offset, kPinTolMm);
  EXPECT_EQ(to.z_rot_point, pins.z_rot_point);
  EXPECT_EQ(to.tool_offset, pins.tool_offset);
}

TEST(Trunnion, PlansAndCentresThatCannotDetermineTheLinesAreRefused) {
  const TrunnionAxes truth = TrueAxes();
  std::vector<TrunnionObservation> two_tilts;
  for (const TrunnionObservation& o : Plan(truth, 0.0, 1))
    if (o.a_deg == 0.0 || o.a_deg == 30.0) two_tilts.push_back(o);
  EXPECT_THROW(FitTrunnion(two_tilts, AxesOf(Controller())), TrunnionError);
  // The sphere moved by 50 um half-way through the plan: no two lines explain the centres.
  std::vector<TrunnionObservation> moved = Plan(truth, 0.0, 1);
  for (size_t i = moved.size() / 2; i < moved.size(); ++i)
    moved[i].centre_machine_mm += Vec3(0.050, 0.0, 0.0);
  EXPECT_THROW(FitTrunnion(moved, AxesOf(Controller())), TrunnionError);
  // One capture 80 um off (A 60, C 180): refused, and that centre named as the worst.
  std::vector<TrunnionObservation> one = Plan(truth, 0.0, 1);
  for (TrunnionObservation& o : one)
    if (o.a_deg == 60.0 && o.c_deg == 180.0) o.centre_machine_mm += Vec3(0.0, 0.080, 0.0);
  try {
    FitTrunnion(one, AxesOf(Controller()));
    ADD_FAILURE() << "one centre 80 um off was fitted";
  } catch (const TrunnionError& e) {
    EXPECT_NE(std::string(e.what()).find("the worst centre, A 60 C 180"), std::string::npos)
        << e.what();
  }
  std::vector<TrunnionObservation> nan = Plan(truth, 0.0, 1);
  nan[3].centre_machine_mm.x() = std::nan("");
  EXPECT_THROW(FitTrunnion(nan, AxesOf(Controller())), TrunnionError);
  TrunnionFitOptions bad;
  bad.centre_sigma_mm = 0.0;
  EXPECT_THROW(FitTrunnion(Plan(truth, 0.0, 1), AxesOf(Controller()), bad), TrunnionError);
}

// The HAL file a calibration rewrites: only the four pins' values change, every other byte (the
// comments, other components' lines, z-rot-point) as it was; a file that does not parse is
// refused before anything is made of it.
TEST(TrunnionHal, ARewriteChangesOnlyThePinsValues) {
  const std::string file =
      "# the trunnion\nsetp xyzac-trt-kins.x-rot-point 120.0\nsetp xyzac-trt-kins.y-rot-point -40\n"
      "setp xyzac-trt-kins.z-rot-point -150.0  # kept\nsetp xyzac-trt-kins.y-offset 2.5\n"
      "setp xyzac-trt-kins.z-offset 60.0\nnet a b => c\n";
  TrtPins pins = ParseTrtPinsHal(file);
  EXPECT_EQ(pins.y_rot_point, -40.0);
  pins.x_rot_point = 120.0300001, pins.y_offset = 2.5659405, pins.z_offset = 59.9649344;
  const std::string out = RewriteTrtPinsHal(file, pins);
  EXPECT_EQ(out,
            "# the trunnion\nsetp xyzac-trt-kins.x-rot-point 120.0300001\n"
            "setp xyzac-trt-kins.y-rot-point -40.0000000\n"
            "setp xyzac-trt-kins.z-rot-point -150.0  # kept\n"
            "setp xyzac-trt-kins.y-offset 2.5659405\nsetp xyzac-trt-kins.z-offset 59.9649344\n"
            "net a b => c\n");
  const TrtPins back = ParseTrtPinsHal(out);
  EXPECT_NEAR(back.x_rot_point, pins.x_rot_point, 1e-10);
  EXPECT_EQ(back.z_rot_point, -150.0);
  EXPECT_THROW(RewriteTrtPinsHal("setp xyzac-trt-kins.x-rot-point 1\n", pins), TrunnionError);
  EXPECT_THROW(ParseTrtPinsHal(file + "setp xyzac-trt-kins.y-offset 3\n"), TrunnionError);
  EXPECT_THROW(ParseTrtPinsHal("setp xyzac-trt-kins.x-rot-point 1e999\n"), TrunnionError);
}

}  // namespace
}  // namespace mlp::calib
