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
  // The calibration pin itself, read with its rise p predicting the crossing.
  EXPECT_GT(nlohmann::json::parse(cal.out).at("rise_share").get<double>(), 0.0);
  const auto rise = RunProcess(kMlp + " setter process --signal " + dir + "/pin.txt --curve " +
                               dir + "/curve.json --rpm 0 --teeth 1 --feed-mm-min 6 --rise --json");
  ASSERT_EQ(rise.exit_code, 0) << rise.err;
  const auto r = nlohmann::json::parse(rise.out);
  EXPECT_EQ(r.at("cause"), "the light crossed the threshold when the rise p predicted");
  EXPECT_NEAR(r.at("predicted_crossing_s").get<double>(), r.at("threshold_time_s").get<double>(),
              0.02);  // 2 um at 6 mm/min: the rise's window
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

namespace {

// The other triggers through the command: without a curve, a reflective setter with its own
// curve, and a tool thinner than the beam (no trigger, how deep it went, exit 3).
TEST(SetterCli, NoCurveReflectiveAndAThinTool) {
  const std::string dir = "/tmp/mlp_setter_cli_modes";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const auto sim = [&](const std::string& args) {
    return RunProcess(kMlp + " setter simulate --out " + dir + "/" + args).exit_code;
  };
  ASSERT_EQ(sim("tool.txt --rpm 1500 --teeth-mm 3.0,3.01 --gap-mm 0.06 --duration-s 1.2 --seed 5"),
            0);
  const std::string tool_args = " --rpm 1500 --teeth 2 --feed-mm-min 6 --json";
  const auto no_curve =
      RunProcess(kMlp + " setter process --signal " + dir + "/tool.txt --no-curve" + tool_args);
  ASSERT_EQ(no_curve.exit_code, 0) << no_curve.err;
  EXPECT_EQ(nlohmann::json::parse(no_curve.out).at("cause"),
            "the leading tooth's line crossed the threshold");
  // Reflective: a pin's reflection calibrated, then a tool's peaks.
  ASSERT_EQ(sim("rpin.txt --reflective --gap-mm 0.15 --duration-s 2.5"), 0);
  ASSERT_EQ(RunProcess(kMlp + " setter calibrate --reflective --signal " + dir +
                       "/rpin.txt --feed-mm-min 6 --out " + dir + "/rcurve.json")
                .exit_code,
            0);
  ASSERT_EQ(sim("rtool.txt --reflective --rpm 1500 --teeth-mm 3.0,3.01 --gap-mm 0.06 "
                "--duration-s 1.2 --seed 6"),
            0);
  const auto reflective = RunProcess(kMlp + " setter process --reflective --signal " + dir +
                                     "/rtool.txt --curve " + dir + "/rcurve.json" + tool_args);
  EXPECT_EQ(reflective.exit_code, 0) << reflective.err;
  // A 10 um wire through a 30 um beam: no trigger; the message says how deep it went.
  ASSERT_EQ(sim("wire.txt --teeth-mm 0.5 --tool-width-mm 0.01 --gap-mm 0.1 --duration-s 2.5"), 0);
  const auto wire = RunProcess(kMlp + " setter process --signal " + dir +
                               "/wire.txt --no-curve --rpm 0 --teeth 1 --feed-mm-min 6");
  EXPECT_EQ(wire.exit_code, 3);
  EXPECT_NE(wire.err.find("over the threshold: a tool thinner than the beam"), std::string::npos)
      << wire.err;
  // A curve and --no-curve at once, or neither: bad arguments.
  EXPECT_EQ(RunProcess(kMlp + " setter process --signal " + dir + "/tool.txt --no-curve --curve " +
                       dir + "/rcurve.json" + tool_args)
                .exit_code,
            2);
  EXPECT_EQ(
      RunProcess(kMlp + " setter process --signal " + dir + "/tool.txt" + tool_args).exit_code, 2);
}

// Issue 56: a D10 two-tooth tool at 3000 rpm and a production feed of 60 mm/min (20 um a turn)
// gives a tooth two minima in the curve's span: no trigger, and the reason says the feed that
// would work; at that feed the same tool triggers. A dip-width diameter far from the nominal
// is withdrawn with the reason, near it kept (the project's own generator: the physics of a
// real beam is issue 56's open part).
TEST(SetterCli, NoTriggerSaysWhyAndAFarDiameterIsWithdrawn) {
  const std::string dir = "/tmp/mlp_setter_cli_why";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  ASSERT_EQ(
      RunProcess(kMlp + " setter simulate --out " + dir + "/pin.txt --gap-mm 0.15 --duration-s 2.5")
          .exit_code,
      0);
  ASSERT_EQ(RunProcess(kMlp + " setter calibrate --signal " + dir +
                       "/pin.txt --feed-mm-min 6 --out " + dir + "/curve.json")
                .exit_code,
            0);
  const auto simulate = [&](const std::string& name, double feed) {
    return RunProcess(kMlp + " setter simulate --out " + dir + "/" + name +
                      " --rpm 3000 --teeth-mm 5.008,5.0 --seed 3 --feed-mm-min " +
                      std::to_string(feed));
  };
  const auto process = [&](const std::string& name, double feed) {
    return kMlp + " setter process --signal " + dir + "/" + name + " --curve " + dir +
           "/curve.json --rpm 3000 --teeth 2 --feed-mm-min " + std::to_string(feed);
  };
  ASSERT_EQ(simulate("fast.txt", 60).exit_code, 0);
  const auto fast = RunProcess(process("fast.txt", 60) + " --json");
  EXPECT_EQ(fast.exit_code, 3);
  const std::string why = nlohmann::json::parse(fast.out).at("no_trigger");
  const auto at = why.find("a feed of at most ");
  ASSERT_NE(at, std::string::npos) << why;
  const double feed = std::stod(why.substr(at + 18));
  EXPECT_GT(feed, 6.0);
  EXPECT_LT(feed, 60.0);
  ASSERT_EQ(simulate("slower.txt", feed).exit_code, 0);
  const auto slower = RunProcess(process("slower.txt", feed) + " --json");
  EXPECT_EQ(slower.exit_code, 0) << slower.err;
  const auto far = nlohmann::json::parse(
      RunProcess(process("slower.txt", feed) + " --json --nominal-diameter-mm 10.5").out);
  EXPECT_TRUE(far.at("diameter_mm").is_null());
  EXPECT_EQ(far.at("diameter_check").get<std::string>().rfind("withdrawn", 0), 0u);
  const auto near = nlohmann::json::parse(
      RunProcess(process("slower.txt", feed) + " --json --nominal-diameter-mm 10.016").out);
  EXPECT_FALSE(near.at("diameter_mm").is_null()) << near.at("diameter_check");
}

}  // namespace
