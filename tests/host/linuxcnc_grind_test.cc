// The grinding cell on the real LinuxCNC (seed 001's "the compensation to the motion
// controller"; issue 21): mlp-grind-hal as a HAL component (samples/linuxcnc/mlprobe-sim/
// grind.hal) on the slide's x, y, z; the sample macro (subs/mlp_grind_point.ngc) grinds a
// cutting point with two strokes, the component takes a frame at each top of stroke and
// measures after a cut, and the macro applies the compensation to G54. The virtual machine's
// wheel is 30 um off at 80 deg: the first point finds it and G54 takes it back, the points
// after it are good. A wheel 120 um further off asks for more than the component's 0.1 mm limit:
// the program stops with the reason and G54 is left as it was.

#include "mlp/grind/grind_job.h"

#include <cmath>
#include <filesystem>
#include <regex>

#include "linuxcnc_machine.h"
#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using geometry::Vec2;
using test::RunProcess;

constexpr double kErrorTolMm = 0.0015;  // grind_station_test: 0.1 um in process; G54 exact
constexpr double kExactMm = 1e-9;

std::string PointCall(const Vec2& c) {
  return "o<mlp_grind_point> call [" + std::to_string(c.x()) + "] [" + std::to_string(c.y()) +
         "] [2] [5] [-3]\n(DEBUG, point feed #<_mlp_grind_feed> d #<_mlp_grind_d_mm>)\n";
}

Vec2 WheelCentre(double s_mm) {
  const geometry::Profile2 p(grind::DemoProfile());
  return p.At(s_mm).point + 1.0 * p.At(s_mm).normal;  // the demo's wheel: R 1 mm
}

TEST(LinuxCncGrind, TheCompensationReachesG54AndAnOversizedOneStops) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  ASSERT_TRUE(fs::exists(test::Program("mlp-grind-hal")))
      << "mlp-grind-hal was not built: it needs linuxcnc-uspace-dev (bash "
         "scripts/install-deps.sh)";
  const fs::path config = test::SampleConfigWith("mlp_linuxcnc_grind", "grind.hal");
  test::LinuxCnc cnc(config, "mlprobe-sim.ini",
                     "PATH=" + fs::path(test::Program("mlp-grind-hal")).parent_path().string() +
                         ":" + std::getenv("PATH"));
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  ASSERT_TRUE(cnc.WaitForPin("mlp-grind.ready")) << test::ReadText(config / "linuxcnc.log");
  const Vec2 error = 0.03 * Vec2(std::cos(80 * M_PI / 180), std::sin(80 * M_PI / 180));
  ASSERT_EQ(cnc.Hal("setp mlp-grind.sim-error-x-mm " + std::to_string(error.x())).exit_code, 0);
  ASSERT_EQ(cnc.Hal("setp mlp-grind.sim-error-y-mm " + std::to_string(error.y())).exit_code, 0);
  std::string program = "G21 G90 G54 G49\nG10 L2 P1 X0 Y0 Z0\n";
  for (const double s : {1.0, 1.6, 2.2}) program += PointCall(WheelCentre(s));
  const auto run = cnc.Run(program + "M2\n");
  ASSERT_TRUE(run.value("ended", false)) << run.dump();
  const std::string log = run.at("errors").dump();
  std::printf("LinuxCNC grind: %s\n", log.c_str());
  const std::regex point("point feed ([0-9.]+) d ([0-9.]+)");
  std::vector<int> feeds;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), point); it != std::sregex_iterator();
       ++it)
    feeds.push_back(static_cast<int>(std::stod((*it)[1])));
  EXPECT_EQ(feeds, (std::vector<int>{1, 0, 0}));  // under-feed, then good
  const Vec2 g54(run.at("g5x_offset")[0].get<double>(), run.at("g5x_offset")[1].get<double>());
  std::printf("LinuxCNC grind: G54 (%.2f, %.2f) um against -error (%.2f, %.2f) um\n", g54.x() * 1e3,
              g54.y() * 1e3, -error.x() * 1e3, -error.y() * 1e3);
  EXPECT_LT((g54 + error).norm(), kErrorTolMm);
  // Each point: a top before its first stroke, between its strokes and at the turn.
  const auto tops = cnc.Hal("getp mlp-grind.captures");
  EXPECT_EQ(std::stoi(tops.out), 9)
      << tops.out << " tops declared: " << cnc.Hal("getp mlp-grind.tops").out;

  // The wheel 150 um off, 120 um beyond what G54 takes back: refused, the program stops, G54
  // stays.
  const Vec2 big = 5 * error;
  ASSERT_EQ(cnc.Hal("setp mlp-grind.sim-error-x-mm " + std::to_string(big.x())).exit_code, 0);
  ASSERT_EQ(cnc.Hal("setp mlp-grind.sim-error-y-mm " + std::to_string(big.y())).exit_code, 0);
  const auto refused = cnc.Run("G21 G90 G54 G49\n" + PointCall(WheelCentre(2.8)) + "M2\n");
  const std::string why = refused.at("errors").dump();
  std::printf("LinuxCNC grind: 120 um further off: %s\n", why.c_str());
  EXPECT_NE(why.find("refused"), std::string::npos) << why;
  EXPECT_NEAR(refused.at("g5x_offset")[0].get<double>(), g54.x(), kExactMm);
  EXPECT_NEAR(refused.at("g5x_offset")[1].get<double>(), g54.y(), kExactMm);
}

}  // namespace
}  // namespace mlp
