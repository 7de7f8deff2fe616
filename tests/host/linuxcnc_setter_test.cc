// The laser tool setter on the real LinuxCNC (seed 003's "skip signal to the CNC"; issue 21):
// mlp-setter-hal as HAL components (samples/linuxcnc/mlprobe-sim/setter.hal) whose skips drive
// motion.probe-input. The sample macros (subs/mlp_setter_length.ngc, mlp_setter_radius.ngc)
// probe with G38.3 at the setter's feed; the move stops at the skip, the setter's edge offset
// is added back, and G10 L1 writes the length or the radius into the tool table. A broken tool
// (shorter than expected beyond the tolerance) stops the program and changes nothing. The
// virtual setters know the truth: a length along Z (not turning) and a two-tooth tool's radius
// along X (turning at 1500 rpm, 10 coolant drops a second).

#include <filesystem>

#include "linuxcnc_machine.h"
#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using test::RunProcess;

// The skip reaches motion a user-space cycle (200 us) and a servo period (1 ms) after the
// processor fires, 0.1 um at 6 mm/min; on a loaded 2-core machine a cycle can take 10 ms
// (1 um). Besides the setter's own edge error (beam_test: 1 um).
constexpr double kLengthTolMm = 0.003;
constexpr double kRadiusTolMm = 0.003;
constexpr double kExactMm = 1e-6;                  // the table holds what G10 wrote
constexpr double kBeamZ = -200.0, kBeamX = 100.0;  // setter.hal
constexpr double kTipRadiusMm = 0.5;               // setter.hal's mlp-setter-z --teeth-mm
constexpr double kLongToothMm = 3.01;              // mlp-setter-x's longest tooth

std::string PathWithSetter() {
  return "PATH=" + fs::path(test::Program("mlp-setter-hal")).parent_path().string() + ":" +
         std::getenv("PATH");
}

std::string LengthProgram(double expected_mm) {
  return "G21 G90 G54 G49\nT12 M6\nG0 X0 Y0\no<mlp_setter_length> call [12] [" +
         std::to_string(expected_mm) + "] [0.5] [" + std::to_string(kBeamZ) +
         "]\n(DEBUG, length #<_mlp_setter_length>)\nM2\n";
}

TEST(LinuxCncSetter, LengthAndRadiusReachTheToolTableAndABrokenToolStops) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  ASSERT_TRUE(fs::exists(test::Program("mlp-setter-hal")))
      << "mlp-setter-hal was not built: it needs linuxcnc-uspace-dev (bash "
         "scripts/install-deps.sh)";
  const fs::path config = test::SampleConfigWith("mlp_linuxcnc_setter_length", "setter.hal");
  test::LinuxCnc cnc(config, "mlprobe-sim.ini", PathWithSetter());
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  for (const char* pin : {"mlp-setter-z.samples", "mlp-setter-x.samples"})
    ASSERT_TRUE(cnc.WaitForPin(pin)) << pin << "\n" << test::ReadText(config / "linuxcnc.log");
  // The virtual tool 12: 101.234 mm from the gauge line to its tip (the table says 101.2).
  const double length = 101.234;
  ASSERT_EQ(
      cnc.Hal("setp mlp-setter-z.sim-base-mm " + std::to_string(length - kTipRadiusMm)).exit_code,
      0);
  const auto measured = cnc.Run(LengthProgram(101.2));
  ASSERT_TRUE(measured.value("ended", false)) << measured.dump();
  const double table_z = measured.at("tools").at("12").at("z");
  std::printf("LinuxCNC setter: length %.4f mm (true %.4f): error %+.2f um; errors %s\n", table_z,
              length, (table_z - length) * 1e3, measured.at("errors").dump().c_str());
  EXPECT_NEAR(table_z, length, kLengthTolMm);

  // The radius of the same tool turning: its longest tooth.
  const auto radius_run =
      cnc.Run("G21 G90 G54 G49\nG0 Y0 Z50\no<mlp_setter_radius> call [12] [3.0] [0.2] [" +
              std::to_string(kBeamX) + "] [1500]\nM2\n");
  ASSERT_TRUE(radius_run.value("ended", false)) << radius_run.dump();
  const double diameter = radius_run.at("tools").at("12").at("diameter");
  std::printf("LinuxCNC setter: radius %.4f mm (true %.4f): error %+.2f um\n", diameter / 2,
              kLongToothMm, (diameter / 2 - kLongToothMm) * 1e3);
  EXPECT_NEAR(diameter / 2, kLongToothMm, kRadiusTolMm);
  EXPECT_NEAR(radius_run.at("tools").at("12").at("z").get<double>(), table_z, kExactMm);

  // Broken: 1.5 mm of the tip gone. No skip down to 0.5 mm below the expected length: the
  // program stops with the reason, the table keeps the length measured before.
  ASSERT_EQ(cnc.Hal("setp mlp-setter-z.sim-base-mm " + std::to_string(length - 1.5 - kTipRadiusMm))
                .exit_code,
            0);
  const auto broken = cnc.Run(LengthProgram(table_z));
  const std::string errors = broken.at("errors").dump();
  std::printf("LinuxCNC setter: a broken tool: %s\n", errors.c_str());
  EXPECT_NE(errors.find("broken tool"), std::string::npos) << errors;
  EXPECT_NEAR(broken.at("tools").at("12").at("z").get<double>(), table_z, kExactMm);
  EXPECT_NEAR(broken.at("tools").at("12").at("diameter").get<double>(), diameter, kExactMm);
}

}  // namespace
}  // namespace mlp
