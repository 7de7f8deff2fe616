// `mlp kinematics check` as a real process on real files (issue 54): sphere centres of a
// trunnion whose true axes are off the five-axis sample machine's pins (read from its own
// trunnion.hal, the file LinuxCNC starts with) by tens of micrometres and 0.01 deg are reported
// beyond the limit with the pins that fit; right pins are within; a plan that cannot determine
// the axes and malformed files are refused with their exit codes. World: synthetic centres (the
// truth is the generator's lines; no probe), 0.5 um of noise.

#include "mlp/calib/trunnion.h"
#include "mlp/calib/trunnion_hal.h"

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

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

// The sample's HAL file copied to `name` (the command rewrites it), its log removed.
fs::path HalCopy(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("mlp_kinematics_" + name + ".hal");
  fs::copy_file(kPins, p, fs::copy_options::overwrite_existing);
  fs::remove(p.string() + ".log");
  return p;
}

test::ProcessRun Calibrate(const std::string& args) {
  return test::RunProcess(test::Program("mlp") + " kinematics calibrate " + args);
}

// The file's lines that are not one of the four pins a calibration may rewrite.
std::string OtherLines(const std::string& text) {
  std::istringstream in(text);
  std::string out, line;
  while (std::getline(in, line)) {
    bool pin = false;
    for (const char* name : {"x-rot-point ", "y-rot-point ", "y-offset ", "z-offset "})
      pin = pin || line.rfind(std::string("setp xyzac-trt-kins.") + name, 0) == 0;
    if (!pin) out += line + "\n";
  }
  return out;
}

TEST(KinematicsCli, CalibrateWritesThePinsThatFitOnceAndRightPinsNotAgain) {
  const calib::TrunnionAxes truth = Off(calib::AxesOf(SamplePins()));
  const std::string centres = CentresFile("cal", truth, {-30, 0, 30, 60, 90}).string();
  const fs::path hal = HalCopy("cal");
  const std::string original = test::ReadText(hal);
  const auto fits = Check("--centres " + centres + " --pins " + kPins + " --json");
  ASSERT_EQ(fits.exit_code, 3) << fits.err;
  const json want = json::parse(fits.out)["pins_that_fit"];

  // Without --write: what it would write, the file as it was, exit 3.
  const auto dry = Calibrate("--centres " + centres + " --pins " + hal.string());
  EXPECT_EQ(dry.exit_code, 3) << dry.err << dry.out;
  EXPECT_NE(dry.out.find("--write to write"), std::string::npos) << dry.out;
  EXPECT_EQ(test::ReadText(hal), original);
  EXPECT_FALSE(fs::exists(hal.string() + ".log"));

  // With --write: the four pins those that fit, every other line kept, before/after logged.
  const auto wrote = Calibrate("--centres " + centres + " --pins " + hal.string() + " --write");
  ASSERT_EQ(wrote.exit_code, 0) << wrote.err << wrote.out;
  const calib::TrtPins now = calib::ParseTrtPinsHal(test::ReadText(hal));
  EXPECT_NEAR(now.x_rot_point, truth.c.point.x(), kFoundTolMm);
  EXPECT_NEAR(now.y_rot_point, truth.c.point.y(), kFoundTolMm);
  EXPECT_NEAR(now.x_rot_point, want["x-rot-point"].get<double>(), 1e-7);
  EXPECT_NEAR(now.y_offset, want["y-offset"].get<double>(), 1e-7);
  EXPECT_NEAR(now.z_offset, 60.0 - 0.043, kFoundTolMm);
  EXPECT_EQ(now.z_rot_point, -150.0);
  EXPECT_EQ(OtherLines(test::ReadText(hal)), OtherLines(original));
  const std::string log = test::ReadText(hal.string() + ".log");
  std::istringstream records(log);
  std::string intent, written, more;
  ASSERT_TRUE(std::getline(records, intent) && std::getline(records, written)) << log;
  EXPECT_FALSE(std::getline(records, more)) << log;
  EXPECT_EQ(json::parse(intent)["state"], "intent");
  const json record = json::parse(written);
  EXPECT_EQ(record["state"], "written");
  ASSERT_EQ(record["changes"].size(), 4u);
  EXPECT_EQ(record["changes"][0]["before_mm"].get<double>(), 120.0);
  EXPECT_NEAR(record["changes"][0]["after_mm"].get<double>(), now.x_rot_point, 1e-7);

  // The same centres against the written pins: nothing to change, nothing written.
  const std::string calibrated = test::ReadText(hal);
  const auto again = Calibrate("--centres " + centres + " --pins " + hal.string() + " --write");
  EXPECT_EQ(again.exit_code, 0) << again.err << again.out;
  EXPECT_NE(again.out.find("nothing to change"), std::string::npos) << again.out;
  EXPECT_EQ(test::ReadText(hal), calibrated);
  EXPECT_EQ(test::ReadText(hal.string() + ".log"), log);
}

TEST(KinematicsCli, CalibrateRefusesAChangeBeyondTheLimitAndTakesAJobsReply) {
  const calib::TrunnionAxes truth = Off(calib::AxesOf(SamplePins()));
  const fs::path centres = CentresFile("far", truth, {-30, 0, 30, 60, 90});
  const fs::path hal = HalCopy("far");
  const std::string original = test::ReadText(hal);
  // x-rot-point is 31 um off: beyond a 20 um limit nothing is written.
  const auto far = Calibrate("--centres " + centres.string() + " --pins " + hal.string() +
                             " --max-change-um 20 --write");
  EXPECT_EQ(far.exit_code, 6) << far.err << far.out;
  EXPECT_NE(far.err.find("x-rot-point by 31"), std::string::npos) << far.err;
  EXPECT_EQ(test::ReadText(hal), original);
  EXPECT_FALSE(fs::exists(hal.string() + ".log"));

  // The kinematics job's reply (its "spheres") gives the same calibration as the centres file.
  json spheres = json::array();
  const json file = json::parse(test::ReadText(centres));
  for (const json& c : file.at("centres"))
    spheres.push_back({{"capture", "k"},
                       {"a_deg", c["a_deg"]},
                       {"c_deg", c["c_deg"]},
                       {"centre_mm", c["centre_mm"]},
                       {"points", 5000}});
  const fs::path reply = fs::temp_directory_path() / "mlp_kinematics_reply.json";
  std::ofstream(reply) << json{{"ok", true}, {"spheres", spheres}}.dump();
  const auto a = Calibrate("--centres " + centres.string() + " --pins " + hal.string() + " --json");
  const auto b = Calibrate("--centres " + reply.string() + " --pins " + hal.string() + " --json");
  EXPECT_EQ(a.exit_code, 3) << a.err;
  EXPECT_EQ(b.exit_code, 3) << b.err;
  EXPECT_EQ(json::parse(a.out)["changes"], json::parse(b.out)["changes"]);
  EXPECT_FALSE(json::parse(a.out)["written"].get<bool>());
  EXPECT_EQ(
      Calibrate("--centres " + reply.string() + " --pins " + hal.string() + " --null-band-um -1")
          .exit_code,
      2);
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
