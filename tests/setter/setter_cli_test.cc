// `mlp setter` as real processes: a pin's signal simulated and calibrated, a two-tooth tool's
// signal processed into a trigger whose edge matches the simulation's truth; no trigger and
// bad files have their exit codes.

#include <cmath>
#include <filesystem>
#include <fstream>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

using mlp::test::RunProcess;
const std::string kMlp = mlp::test::Program("mlp");
constexpr double kEdgeTolMm = 0.001;

TEST(SetterCli, SimulatesCalibratesAndTriggers) {
  const std::string dir = "/tmp/mlp_setter_cli";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto pin = RunProcess(kMlp + " setter simulate --out " + dir +
                              "/pin.txt --gap-mm 0.15 --duration-s 2.5");
  ASSERT_EQ(pin.exit_code, 0) << pin.err;
  const auto cal = RunProcess(kMlp + " setter calibrate --signal " + dir +
                              "/pin.txt --feed-mm-min 6 --out " + dir + "/curve.json --json");
  ASSERT_EQ(cal.exit_code, 0) << cal.err;
  EXPECT_EQ(nlohmann::json::parse(cal.out).at("format"), "mlprobe-beam-curve/1");
  const auto tool = RunProcess(kMlp + " setter simulate --out " + dir +
                               "/tool.txt --rpm 1500 --teeth-mm 3.0,3.01 --gap-mm 0.06 "
                               "--duration-s 1.2 --drops-per-s 10 --seed 4");
  ASSERT_EQ(tool.exit_code, 0) << tool.err;
  const std::string process = kMlp + " setter process --signal " + dir + "/tool.txt --curve " +
                              dir + "/curve.json --rpm 1500 --teeth 2 --feed-mm-min 6";
  const auto run = RunProcess(process + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  std::ifstream in(dir + "/tool.txt.truth.json");
  const auto truth = nlohmann::json::parse(in);
  const double latched =
      truth.at("axis_start_mm").get<double>() +
      truth.at("axis_feed_mm_per_sample").get<double>() * j.at("trigger_sample").get<double>();
  const double edge = latched - j.at("edge_offset_mm").get<double>();
  EXPECT_NEAR(edge, truth.at("axis_at_edge_mm").get<double>(), kEdgeTolMm);
  constexpr double kDiameterTolMm = 0.03;  // the dips' widths through the command
  EXPECT_NEAR(j.at("diameter_mm").get<double>(), 6.02, kDiameterTolMm);
  const auto text = RunProcess(process);
  EXPECT_NE(text.out.find("trigger at sample"), std::string::npos) << text.out;
  // A tool that never reaches the beam: no trigger, exit 3; a file that is not a signal: 2.
  ASSERT_EQ(RunProcess(kMlp + " setter simulate --out " + dir +
                       "/far.txt --rpm 1500 --teeth-mm 3,3 --gap-mm 1 --drops-per-s 30")
                .exit_code,
            0);
  const auto far = RunProcess(kMlp + " setter process --signal " + dir + "/far.txt --curve " + dir +
                              "/curve.json --rpm 1500 --teeth 2 --feed-mm-min 6");
  EXPECT_EQ(far.exit_code, 3) << far.err;
  EXPECT_NE(far.err.find("no trigger"), std::string::npos) << far.err;
  EXPECT_EQ(RunProcess(kMlp + " setter process --signal " + dir + "/curve.json --curve " + dir +
                       "/curve.json --rpm 1500 --teeth 2 --feed-mm-min 6")
                .exit_code,
            2);
  EXPECT_EQ(RunProcess(kMlp + " setter calibrate --signal " + dir +
                       "/far.txt --feed-mm-min 6 --out " + dir + "/bad.json")
                .exit_code,
            3);  // the beam is never blocked: no curve
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.json"));
}

}  // namespace
