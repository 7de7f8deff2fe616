// The five-axis machine of issue 54 on the real LinuxCNC: samples/linuxcnc/mlprobe-5axis, a
// trunnion (A tilting about X carrying a rotary table C) under Debian's xyzac-trt-kins. The
// kinematics' parameters are read from the running machine's HAL pins (never typed twice), and
// mlprobe's model of the table's motion (calib::MachineFromTable: C turns first about its line,
// then A turns both) puts every axis position, which LinuxCNC reports in the table's frame,
// exactly on the joints LinuxCNC drives, for the shipped pins and for pins changed while the
// machine runs (as a kinematics calibration would change them).

#include "mlp/calib/trunnion.h"

#include <filesystem>
#include <sstream>

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
  const fs::path dir = fs::temp_directory_path() / "mlp_linuxcnc_5axis";
  fs::remove_all(dir);
  fs::copy(test::SourceDir() + "/samples/linuxcnc/mlprobe-5axis", dir, fs::copy_options::recursive);
  return dir;
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

}  // namespace
}  // namespace mlp
