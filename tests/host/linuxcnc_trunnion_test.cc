// The five-axis machine of issue 54 on the real LinuxCNC: samples/linuxcnc/mlprobe-5axis, a
// trunnion (A tilting about X carrying a rotary table C) under Debian's xyzac-trt-kins. The
// kinematics' parameters are read from the running machine's HAL pins (never typed twice), and
// mlprobe's model of the table's motion (calib::MachineFromTable: C turns first about its line,
// then A turns both) puts every axis position, which LinuxCNC reports in the table's frame,
// exactly on the joints LinuxCNC drives, for the shipped pins and for pins changed while the
// machine runs (as a kinematics calibration would change them); and H from the joints and the
// live pins (`mlp kinematics flange-pose`) has its origin where LinuxCNC's TCP puts the tool.

#include "mlp/calib/trunnion.h"

#include <filesystem>
#include <sstream>
#include <vector>

#include "linuxcnc_machine.h"
#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using test::RunProcess;

constexpr double kSameMm = 1e-6;  // two computations of one rigid motion: rounding only

fs::path FiveAxisConfig() {
  // Both sample machines: the five-axis one's M-codes are the three-axis one's (USER_M_PATH).
  const fs::path dir = fs::temp_directory_path() / "mlp_linuxcnc_5axis";
  fs::remove_all(dir);
  fs::copy(test::SourceDir() + "/samples/linuxcnc", dir, fs::copy_options::recursive);
  return dir / "mlprobe-5axis";
}

// The kinematics' pins as the running machine holds them.
calib::TrtPins ReadPins(const test::LinuxCnc& cnc) {
  const auto pin = [&](const std::string& name) {
    const auto r = cnc.Hal("-s getp xyzac-trt-kins." + name);
    EXPECT_EQ(r.exit_code, 0) << name << ": " << r.err;
    return std::stod(r.out);
  };
  calib::TrtPins p;
  p.x_rot_point = pin("x-rot-point"), p.y_rot_point = pin("y-rot-point");
  p.z_rot_point = pin("z-rot-point"), p.y_offset = pin("y-offset");
  p.z_offset = pin("z-offset"), p.tool_offset = pin("tool-offset");
  return p;
}

// Moves to a table position at (a, c) and checks the joints against the model with the pins.
void CheckPose(const test::LinuxCnc& cnc,
               const calib::TrtPins& pins,
               const geometry::Vec3& table,
               double a_deg,
               double c_deg) {
  std::ostringstream program;
  program.precision(10);
  program << "G21 G90 G54\nG0 X" << table.x() << " Y" << table.y() << " Z" << table.z() << " A"
          << a_deg << " C" << c_deg << "\nM2\n";
  const auto state = cnc.Run(program.str());
  ASSERT_TRUE(state.contains("joints") && state["joints"].size() == 5) << state.dump();
  ASSERT_TRUE(state["errors"].empty()) << state.dump();
  const auto& axes = state["axes"];
  const auto& joints = state["joints"];
  EXPECT_NEAR(axes[3].get<double>(), a_deg, 1e-9);
  EXPECT_NEAR(axes[5].get<double>(), c_deg, 1e-9);
  const geometry::Vec3 in_table(axes[0].get<double>(), axes[1].get<double>(),
                                axes[2].get<double>());
  const geometry::Vec3 machine =
      calib::MachineFromTable(calib::AxesOf(pins), a_deg, c_deg) * in_table;
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(joints[k].get<double>(), machine[k], kSameMm)
        << "joint " << k << " at A " << a_deg << " C " << c_deg;
  // H as M101 will have it: `mlp kinematics flange-pose` from the joints and the live pins; its
  // origin (the gauge point) in the table's frame is where LinuxCNC's TCP says the tool is.
  std::ostringstream cmd;
  cmd.precision(17);
  cmd << test::Program("mlp") << " kinematics flange-pose --pin x-rot-point=" << pins.x_rot_point
      << " --pin y-rot-point=" << pins.y_rot_point << " --pin z-rot-point=" << pins.z_rot_point
      << " --pin y-offset=" << pins.y_offset << " --pin z-offset=" << pins.z_offset
      << " --pin tool-offset=" << pins.tool_offset << " --joints " << joints[0].get<double>() << ","
      << joints[1].get<double>() << "," << joints[2].get<double>() << "," << joints[3].get<double>()
      << "," << joints[4].get<double>();
  const auto h = RunProcess(cmd.str());
  ASSERT_EQ(h.exit_code, 0) << h.err;
  const auto pose = nlohmann::json::parse(h.out);
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(pose["translation_mm"][static_cast<size_t>(k)].get<double>(), in_table[k], kSameMm)
        << "H's origin, axis " << k << " at A " << a_deg << " C " << c_deg;
}

TEST(LinuxCncTrunnion, TheTablesMotionIsTheControllersWithThePinsItHolds) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  const fs::path config = FiveAxisConfig();
  test::LinuxCnc cnc(config, "mlprobe-5axis.ini");
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  ASSERT_TRUE(cnc.WaitForPin("xyzac-trt-kins.x-rot-point"))
      << test::ReadText(config / "linuxcnc.log");
  // The pin exists once the kinematics are loaded, before trunnion.hal has set it: a first
  // program (machine on, homed) runs after every HAL file.
  ASSERT_TRUE(cnc.Run("M2\n")["errors"].empty());
  const calib::TrtPins shipped = ReadPins(cnc);
  EXPECT_EQ(shipped.x_rot_point, 120.0) << "trunnion.hal sets the pins at start";
  const geometry::Vec3 on_table(135.0, -22.0, -95.0);
  CheckPose(cnc, shipped, on_table, 0.0, 0.0);
  CheckPose(cnc, shipped, on_table, 30.0, 45.0);
  CheckPose(cnc, shipped, on_table + geometry::Vec3(-40, 15, 20), -20.0, 200.0);
  CheckPose(cnc, shipped, on_table, 90.0, -30.0);
  // Pins changed while the machine runs, by tens of micrometres (a calibration's size) and more.
  ASSERT_EQ(cnc.Hal("setp xyzac-trt-kins.x-rot-point 120.031").exit_code, 0);
  ASSERT_EQ(cnc.Hal("setp xyzac-trt-kins.y-offset 2.544").exit_code, 0);
  ASSERT_EQ(cnc.Hal("setp xyzac-trt-kins.z-offset 57.0").exit_code, 0);
  const calib::TrtPins changed = ReadPins(cnc);
  EXPECT_EQ(changed.z_offset, 57.0);
  CheckPose(cnc, changed, on_table, 45.0, 135.0);
  CheckPose(cnc, changed, on_table + geometry::Vec3(10, -30, 5), -60.0, 10.0);
}

// `mlp kinematics plan` on the same machine: its program, run by LinuxCNC, stops the gauge point
// straight above the sphere where the running controller's kinematics (its pins, read from HAL)
// put the sphere at each A and C, every turn made at the clearance height, and leaves the
// trunnion's kinematics on. The stops are read back as the program says them (DEBUG lines).
TEST(LinuxCncTrunnion, TheSpherePlansProgramStopsOverTheSphereAtEveryTiltAndTurn) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  const fs::path config = FiveAxisConfig();
  const fs::path program = config / "sphere_plan.ngc";
  const auto planned = RunProcess(test::Program("mlp") + " kinematics plan --pins " +
                                  (config / "trunnion.hal").string() +
                                  " --sphere 175,-25,-70 --a -30,0,30,60 --c 3 --table-radius 150"
                                  " --table-top -90 --json --out " +
                                  program.string());
  ASSERT_EQ(planned.exit_code, 0) << planned.err;
  const nlohmann::json plan = nlohmann::json::parse(planned.out);
  ASSERT_EQ(plan["stops"].size(), 12u);
  test::LinuxCnc cnc(config, "mlprobe-5axis.ini");
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  const auto state = cnc.Run(test::ReadText(program));
  const calib::TrtPins pins = ReadPins(cnc);
  std::vector<std::vector<double>> stops;
  for (const auto& e : state["errors"]) {
    std::istringstream words(e.get<std::string>());
    std::string mlp, stop;
    int n = 0;
    std::vector<double> v(5);
    if (words >> mlp >> stop >> n >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] && stop == "stop")
      stops.push_back(v);
  }
  ASSERT_EQ(stops.size(), 12u) << state.dump();
  const double above = 140.0 + 125.0;  // the default probe length and stand-off
  for (size_t i = 0; i < stops.size(); ++i) {
    const auto& want = plan["stops"][i];
    const double a = want["a_deg"].get<double>(), c = want["c_deg"].get<double>();
    EXPECT_NEAR(stops[i][3], a, 1e-6);
    EXPECT_NEAR(stops[i][4], c, 1e-6);
    const geometry::Vec3 sphere =
        calib::MachineFromTable(calib::AxesOf(pins), a, c) * geometry::Vec3(175.0, -25.0, -70.0);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(stops[i][static_cast<size_t>(k)], sphere[k] + (k == 2 ? above : 0.0), 1e-5)
          << "stop " << i + 1 << " axis " << k;
    EXPECT_LT(stops[i][2], plan["clear_gauge_z_mm"].get<double>());
  }
  EXPECT_EQ(cnc.Hal("-s getp motion.switchkins-type").out.substr(0, 1), "0")
      << "the trunnion's kinematics on again";
}

}  // namespace
}  // namespace mlp
