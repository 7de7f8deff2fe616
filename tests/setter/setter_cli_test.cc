// `mlp setter` as real processes: a pin's signal simulated and calibrated, a two-tooth tool's
// signal processed into a trigger whose edge matches the simulation's truth; no trigger and
// bad files have their exit codes.

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>

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
  EXPECT_EQ(nlohmann::json::parse(cal.out).at("format"), "mlprobe-beam-curve/2");
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
  // No diameter from the dips' widths (issue 56): refused, with the reason.
  EXPECT_TRUE(j.at("diameter_mm").is_null());
  EXPECT_NE(j.at("diameter_refused").get<std::string>().find("divergence"), std::string::npos);
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

// An empty `dir` with a pin's signal and its curve (curve.json) in it.
bool FreshDirWithACurve(const std::string& dir) {
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return RunProcess(kMlp + " setter simulate --out " + dir +
                    "/pin.txt --gap-mm 0.15 --duration-s 2.5")
                 .exit_code == 0 &&
         RunProcess(kMlp + " setter calibrate --signal " + dir + "/pin.txt --feed-mm-min 6 --out " +
                    dir + "/curve.json")
                 .exit_code == 0;
}

// Issue 56: a D10 two-tooth tool at 3000 rpm and a production feed of 60 mm/min (20 um a turn)
// triggers within 2 um (each minimum on the curve says where its tooth is, at the feed's known
// slope). At 80 um a turn a tooth's minima can miss the curve's span: no trigger, the reason
// names the feed that works, and at that feed the same tool triggers within 2 um.
TEST(SetterCli, TriggersAtAProductionFeedAndSaysWhyWhenTheFeedIsTooHigh) {
  const std::string dir = "/tmp/mlp_setter_cli_why";
  ASSERT_TRUE(FreshDirWithACurve(dir));
  const auto simulate = [&](const std::string& name, double feed) {
    return RunProcess(kMlp + " setter simulate --out " + dir + "/" + name +
                      " --rpm 3000 --teeth-mm 5.008,5.0 --seed 3 --gap-mm 0.2 --feed-mm-min " +
                      std::to_string(feed));
  };
  const auto edge_error_mm = [&](const std::string& name, double feed, std::string* why) {
    const auto run = RunProcess(kMlp + " setter process --signal " + dir + "/" + name +
                                " --curve " + dir + "/curve.json --rpm 3000 --teeth 2 --json " +
                                "--feed-mm-min " + std::to_string(feed));
    const auto j = nlohmann::json::parse(run.out);
    if (!j.at("triggered").get<bool>()) {
      *why = j.at("no_trigger");
      return std::nan("");
    }
    std::ifstream in(dir + "/" + name + ".truth.json");
    const auto truth = nlohmann::json::parse(in);
    const double latched =
        truth.at("axis_start_mm").get<double>() +
        truth.at("axis_feed_mm_per_sample").get<double>() * j.at("trigger_sample").get<double>();
    return latched - j.at("edge_offset_mm").get<double>() -
           truth.at("axis_at_edge_mm").get<double>();
  };
  constexpr double kProductionTolMm = 0.002;  // issue 56: up to 20 um a turn
  std::string why;
  ASSERT_EQ(simulate("production.txt", 60).exit_code, 0);
  EXPECT_NEAR(edge_error_mm("production.txt", 60, &why), 0.0, kProductionTolMm) << why;
  ASSERT_EQ(simulate("fast.txt", 240).exit_code, 0);
  EXPECT_TRUE(std::isnan(edge_error_mm("fast.txt", 240, &why)));
  const auto at = why.find("a feed of at most ");
  ASSERT_NE(at, std::string::npos) << why;
  const double feed = std::stod(why.substr(at + 18));
  EXPECT_GT(feed, 60.0);
  EXPECT_LT(feed, 240.0);
  ASSERT_EQ(simulate("slower.txt", feed).exit_code, 0);
  EXPECT_NEAR(edge_error_mm("slower.txt", feed, &why), 0.0, kProductionTolMm) << why;
}

// A real setter's log (mlprobe-beam-signal/2): ADC codes, timestamps, the axis. The edge is
// then read off the axis itself; a lost sample and a saturated receiver are refused.
TEST(SetterCli, ARealSettersLogGivesTheEdgeOnItsAxisAndRefusesLostOrSaturatedSamples) {
  const std::string dir = "/tmp/mlp_setter_cli_log";
  ASSERT_TRUE(FreshDirWithACurve(dir));
  ASSERT_EQ(RunProcess(kMlp + " setter simulate --out " + dir +
                       "/tool.txt --rpm 1500 --teeth-mm 3.0,3.01 --gap-mm 0.06 --duration-s 1.2")
                .exit_code,
            0);
  std::ifstream truth_in(dir + "/tool.txt.truth.json");
  const auto truth = nlohmann::json::parse(truth_in);
  const double a0 = truth.at("axis_start_mm"), da = truth.at("axis_feed_mm_per_sample");
  // The volts as a 12-bit ADC over 5 V writes them, with time and axis.
  const auto write_log = [&](const std::string& name, long skip_sample, double gain) {
    std::ifstream in(dir + "/tool.txt");
    std::ofstream out(dir + "/" + name);
    out << std::setprecision(10);
    std::string line;
    std::getline(in, line);
    out << "# mlprobe-beam-signal/2 sample_rate_hz=80000 adc_bits=12 full_scale_v=5\n"
        << "# columns: t_s code axis_mm\n";
    for (long i = 0; std::getline(in, line); ++i) {
      if (i == skip_sample) continue;
      const long code = std::clamp(std::lround(std::stod(line) * gain / 5.0 * 4096), 0L, 4095L);
      const auto at = static_cast<double>(i);
      out << at / 80000.0 << " " << code << " " << a0 + da * at << "\n";
    }
  };
  const std::string process = kMlp + " setter process --curve " + dir +
                              "/curve.json --rpm 1500 --teeth 2 --feed-mm-min 6 --json --signal ";
  write_log("log.txt", -1, 1.0);
  const auto run = RunProcess(process + dir + "/log.txt");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  constexpr double kAdcEdgeTolMm = 0.001;  // 12 bits over 5 V: 0.03 % of the clear 4 V
  EXPECT_NEAR(nlohmann::json::parse(run.out).at("edge_axis_mm").get<double>(),
              truth.at("axis_at_edge_mm").get<double>(), kAdcEdgeTolMm);
  write_log("lost.txt", 5000, 1.0);
  const auto lost = RunProcess(process + dir + "/lost.txt");
  EXPECT_EQ(lost.exit_code, 2);
  EXPECT_NE(lost.err.find("samples lost"), std::string::npos) << lost.err;
  write_log("saturated.txt", -1, 1.3);  // 4 V x 1.3 over 5 V full scale
  const auto saturated = RunProcess(process + dir + "/saturated.txt");
  EXPECT_EQ(saturated.exit_code, 3);
  EXPECT_NE(saturated.err.find("saturates"), std::string::npos) << saturated.err;
}

}  // namespace
