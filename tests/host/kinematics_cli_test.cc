// `mlp kinematics check` as a real process on real files (issue 54): sphere centres of a
// trunnion whose true axes are off the five-axis sample machine's pins (read from its own
// trunnion.hal, the file LinuxCNC starts with) by tens of micrometres and 0.01 deg are reported
// beyond the limit with the pins that fit; right pins are within; a plan that cannot determine
// the axes and malformed files are refused with their exit codes. World: synthetic centres (the
// truth is the generator's lines; no probe), 0.5 um of noise.

#include "mlp/calib/trunnion.h"

#include <filesystem>
#include <fstream>
#include <random>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using geometry::Pose3;
using geometry::Vec3;
using json = nlohmann::json;

constexpr double kDeg = 3.14159265358979323846 / 180.0;
constexpr double kNoiseMm = 0.0005;
constexpr double kFoundTolMm = 0.001;  // the pins that fit, against the true lines
const std::string kPins = test::SourceDir() + "/samples/linuxcnc/mlprobe-5axis/trunnion.hal";

calib::TrtPins SamplePins() {
  // The sample's values, as the file says (the test of the parser is that these agree).
  calib::TrtPins p;
  p.x_rot_point = 120.0, p.y_rot_point = -40.0, p.z_rot_point = -150.0;
  p.y_offset = 2.5, p.z_offset = 60.0;
  return p;
}

calib::TrunnionAxes Off(const calib::TrunnionAxes& pinned) {
  calib::TrunnionAxes t = pinned;
  t.c.point += Vec3(0.031, -0.024, 0.0);
  t.a.point += Vec3(0.0, 0.018, -0.043);
  t.a.direction = Eigen::AngleAxisd(0.012 * kDeg, Vec3::UnitZ()) * t.a.direction;
  return t;
}

// The centres file of a plan: A -30..90 by 30, C 0..270 by 90, the sphere 60 mm off C.
fs::path CentresFile(const std::string& name,
                     const calib::TrunnionAxes& truth,
                     const std::vector<double>& a_values) {
  std::mt19937 rng(77);
  std::normal_distribution<double> n(0.0, kNoiseMm);
  json centres = json::array();
  for (double a : a_values) {
    for (double c : {0.0, 90.0, 180.0, 270.0}) {
      const Vec3 m = calib::MachineFromTable(truth, a, c) * Vec3(180.0, -30.0, -60.0) +
                     Vec3(n(rng), n(rng), n(rng));
      centres.push_back({{"a_deg", a}, {"c_deg", c}, {"centre_mm", {m.x(), m.y(), m.z()}}});
    }
  }
  const fs::path p = fs::temp_directory_path() / ("mlp_kinematics_" + name + ".json");
  std::ofstream(p) << json{{"format", "mlprobe-trunnion-centres/1"}, {"centres", centres}}.dump();
  return p;
}

test::ProcessRun Check(const std::string& args) {
  return test::RunProcess(test::Program("mlp") + " kinematics check " + args);
}

TEST(KinematicsCli, AxesOffThePinsAreReportedBeyondTheLimitWithThePinsThatFit) {
  const calib::TrunnionAxes truth = Off(calib::AxesOf(SamplePins()));
  const fs::path svg = fs::temp_directory_path() / "mlp_kinematics_check.svg";
  fs::remove(svg);
  const auto r = Check("--centres " + CentresFile("off", truth, {-30, 0, 30, 60, 90}).string() +
                       " --pins " + kPins + " --svg " + svg.string() + " --json");
  ASSERT_EQ(r.exit_code, 3) << r.err << r.out;
  const json j = json::parse(r.out);
  EXPECT_FALSE(j["within"].get<bool>());
  EXPECT_EQ(j["centres"], 20);
  // Where LinuxCNC's lines (A along X, C along Z) meet the true ones: the true C line is
  // upright, so its x, y are the fit's; the true A line turned about Z keeps its y and z.
  const auto& fits = j["pins_that_fit"];
  EXPECT_NEAR(fits["x-rot-point"].get<double>(), truth.c.point.x(), kFoundTolMm);
  EXPECT_NEAR(fits["y-rot-point"].get<double>(), truth.c.point.y(), kFoundTolMm);
  EXPECT_NEAR(fits["z-offset"].get<double>(), 60.0 - 0.043, kFoundTolMm);
  EXPECT_NEAR(j["squareness_deg"][0]["found"].get<double>(), 0.012, 0.001);
  EXPECT_FALSE(j["pivots_mm"][0]["within"].get<bool>()) << "31 um against a 10 um limit";
  EXPECT_LT(j["residual_rms_mm"].get<double>(), 3 * kNoiseMm);
  ASSERT_TRUE(fs::exists(svg));
  const std::string picture = test::ReadText(svg);
  size_t circles = 0;
  for (size_t at = picture.find("<circle"); at != std::string::npos;
       at = picture.find("<circle", at + 1))
    ++circles;
  EXPECT_EQ(circles, 20u + 4u) << "every centre seen along X, the four at A = 0 along Z";
}

TEST(KinematicsCli, RightPinsAreWithinAndSaidSo) {
  const auto r =
      Check("--centres " +
            CentresFile("right", calib::AxesOf(SamplePins()), {-30, 0, 30, 60, 90}).string() +
            " --pins " + kPins);
  EXPECT_EQ(r.exit_code, 0) << r.err << r.out;
  EXPECT_NE(r.out.find("within the limits"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("x-rot-point: "), std::string::npos) << r.out;
  // The same pins as the running machine holds them (halcmd getp), the same verdict and figures.
  const auto live =
      Check("--centres " + (fs::temp_directory_path() / "mlp_kinematics_right.json").string() +
            " --pin x-rot-point=120 --pin y-rot-point=-40 --pin z-rot-point=-150"
            " --pin y-offset=2.5 --pin z-offset=60");
  EXPECT_EQ(live.exit_code, 0) << live.err;
  EXPECT_EQ(live.out, r.out);
}

TEST(KinematicsCli, WhatCannotDetermineTheAxesAndBadFilesAreRefused) {
  const calib::TrunnionAxes truth = calib::AxesOf(SamplePins());
  const auto two_tilts =
      Check("--centres " + CentresFile("two", truth, {0, 30}).string() + " --pins " + kPins);
  EXPECT_EQ(two_tilts.exit_code, 4) << two_tilts.err;
  EXPECT_NE(two_tilts.err.find("A positions"), std::string::npos) << two_tilts.err;
  EXPECT_TRUE(two_tilts.out.empty());
  const fs::path bad = fs::temp_directory_path() / "mlp_kinematics_bad.json";
  std::ofstream(bad) << R"({"format": "mlprobe-trunnion-centres/1", "centres": [{"a_deg": 0}]})";
  EXPECT_EQ(Check("--centres " + bad.string() + " --pins " + kPins).exit_code, 2);
  const fs::path pins = fs::temp_directory_path() / "mlp_kinematics_pins.hal";
  std::ofstream(pins) << "setp xyzac-trt-kins.x-rot-point 120\n";  // the others missing
  const auto missing = Check("--centres " + CentresFile("p", truth, {-30, 0, 30}).string() +
                             " --pins " + pins.string());
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("y-rot-point"), std::string::npos) << missing.err;
  EXPECT_EQ(Check("--pins " + kPins).exit_code, 2) << "no centres";
}

TEST(KinematicsCli, APlanHasItsStopsOverTheSphereAndRefusesWhatCannotDetermineTheAxes) {
  const auto r = test::RunProcess(test::Program("mlp") + " kinematics plan --pins " + kPins +
                                  " --sphere 175,-25,-70 --c 3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json j = json::parse(r.out);
  ASSERT_EQ(j["stops"].size(), 15u) << "A -30, 0, 30, 60, 90 by default, C three times";
  const calib::TrunnionAxes axes = calib::AxesOf(SamplePins());
  for (const auto& s : j["stops"]) {
    const Vec3 over =
        calib::MachineFromTable(axes, s["a_deg"].get<double>(), s["c_deg"].get<double>()) *
            Vec3(175.0, -25.0, -70.0) +
        Vec3(0, 0, 140.0 + 125.0);
    const auto& g = s["gauge_machine_mm"];
    EXPECT_NEAR(g[0].get<double>(), over.x(), 1e-9);
    EXPECT_NEAR(g[2].get<double>(), over.z(), 1e-9);
    EXPECT_LT(g[2].get<double>() + 20.0, j["clear_gauge_z_mm"].get<double>() + 1e-9);
  }
  const std::string plan = test::Program("mlp") + " kinematics plan --pins " + kPins;
  EXPECT_EQ(test::RunProcess(plan + " --sphere 175,-25,-70 --a 0,30").exit_code, 2);
  EXPECT_EQ(test::RunProcess(plan + " --sphere 175,-25").exit_code, 2);
  EXPECT_EQ(test::RunProcess(plan + " --sphere 175,-25,-70 --c 2").exit_code, 2);
}

TEST(KinematicsCli, TheFlangePoseIsTheKinematicsFromTheFileOrTheLivePins) {
  const std::string mlp = test::Program("mlp") + " kinematics flange-pose ";
  const Pose3 want =
      calib::TableFromFlange(calib::AxesOf(SamplePins()), Vec3(100, -20, 150), 30.0, 45.0, 90.0);
  for (const std::string& pins :
       {"--pins " + kPins,
        std::string("--pin x-rot-point=120 --pin y-rot-point=-40 --pin z-rot-point=-150 "
                    "--pin y-offset=2.5 --pin z-offset=60")}) {
    const auto r = test::RunProcess(mlp + pins + " --joints 100,-20,150,30,45 --spindle 90");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const json h = json::parse(r.out);
    const Vec3 t(h["translation_mm"][0], h["translation_mm"][1], h["translation_mm"][2]);
    const Vec3 rv(h["rotation_vector_rad"][0], h["rotation_vector_rad"][1],
                  h["rotation_vector_rad"][2]);
    EXPECT_LT((t - want.translation()).norm(), 1e-9) << pins;
    const Eigen::Matrix3d r_got = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
    EXPECT_LT((r_got - want.linear()).norm(), 1e-9) << pins;
  }
  EXPECT_EQ(test::RunProcess(mlp + "--pins " + kPins + " --joints 1,2,3,4").exit_code, 2);
  EXPECT_EQ(
      test::RunProcess(mlp + "--pins " + kPins + " --pin z-offset=1 --joints 1,2,3,4,5").exit_code,
      2)
      << "the pins from two sources";
  EXPECT_EQ(test::RunProcess(mlp + "--pin x-rot-point=1 --joints 1,2,3,4,5").exit_code, 2)
      << "pins missing";
}

}  // namespace
}  // namespace mlp
