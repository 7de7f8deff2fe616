// `mlp tool strobe` as a real process: the plan in text and JSON, the exit codes, and a refused
// plan's reason on stderr with nothing on stdout.

#include <filesystem>
#include <fstream>

#include "process_run.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

using mlp::test::RunProcess;
const std::string kMlp = MLP_BINARY;

TEST(ToolCli, PlansTheStrobe) {
  const auto text = RunProcess(kMlp + " tool strobe --rpm 7200 --fps 45 --resolution-deg 3.6");
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("100 positions, 2.22 s"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("2 per image"), std::string::npos) << text.out;
  const auto json = RunProcess(kMlp + " tool strobe --rpm 70 --fps 60 --resolution-deg 1 --json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const auto plan = nlohmann::json::parse(json.out);
  EXPECT_EQ(plan.at("skip"), 7);
  EXPECT_EQ(plan.at("position").size(), 360u);
}

TEST(ToolCli, ExitCodesSayWhatWentWrong) {
  const auto refused = RunProcess(kMlp + " tool strobe --rpm 72 --fps 60 --resolution-deg 1");
  EXPECT_EQ(refused.exit_code, 3);
  EXPECT_TRUE(refused.out.empty());
  EXPECT_NE(refused.err.find("needs 70.00 rpm"), std::string::npos) << refused.err;
  EXPECT_EQ(RunProcess(kMlp + " tool strobe --rpm 7200").exit_code, 2);
  EXPECT_EQ(RunProcess(kMlp + " tool strobe --rpm x --fps 1 --resolution-deg 1").exit_code, 2);
  EXPECT_EQ(RunProcess(kMlp + " tool").exit_code, 2);
}

TEST(ToolCli, RendersTheVirtualToolCamerasFrames) {
  const std::string dir = "/tmp/mlp_tool_cli_render";
  std::filesystem::remove_all(dir);
  const std::string tool = std::string(MLP_SOURCE_DIR) + "/samples/tools/endmill_d10_z4_new.json";
  const auto run = RunProcess(kMlp + " tool render --tool " + tool + " --out " + dir +
                              " --rpm 5000 --fps 50 --resolution-deg 90 --seed 4");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/frame_0003.pgm"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/truth.json"));
  const auto bad = RunProcess(kMlp + " tool render --tool /nonexistent.json --out " + dir +
                              " --rpm 5000 --fps 50 --resolution-deg 90");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("cannot read"), std::string::npos) << bad.err;
}

TEST(ToolCli, MeasuresTheRenderedToolAndDrawsTheOverlay) {
  const std::string dir = "/tmp/mlp_tool_cli_measure";
  std::filesystem::remove_all(dir);
  const std::string tools = std::string(MLP_SOURCE_DIR) + "/samples/tools/";
  const auto render =
      RunProcess(kMlp + " tool render --tool " + tools + "endmill_d10_z4_worn.json --out " + dir +
                 " --rpm 5000 --fps 50 --resolution-deg 7.2 --seed 5");
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const auto run = RunProcess(kMlp + " tool measure --images " + dir + " --tool " + tools +
                              "endmill_d10_z4_new.json --overlay " + dir + "/overlay.png --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto m = nlohmann::json::parse(run.out);
  // Edge 2 cuts the wall (5.006) and the floor (4 um long): the tool table's figures.
  EXPECT_NEAR(m.at("diameter_mm").get<double>(), 10.012, 0.002);
  EXPECT_NEAR(m.at("length_mm").get<double>(), 75.004, 0.001);
  int findings = 0;
  for (const auto& f : m.at("flutes")) findings += static_cast<int>(f.at("findings").size());
  EXPECT_EQ(findings, 2);  // the chip and the build-up
  // Stored as the tool's reference, the same images show nothing new.
  const auto save = RunProcess(kMlp + " tool measure --images " + dir + " --tool " + tools +
                               "endmill_d10_z4_new.json --save-reference " + dir + "/ref.json");
  ASSERT_EQ(save.exit_code, 0) << save.err;
  const auto again =
      RunProcess(kMlp + " tool measure --images " + dir + " --tool " + dir + "/ref.json --json");
  ASSERT_EQ(again.exit_code, 0) << again.err;
  int later = 0;
  for (const auto& f : nlohmann::json::parse(again.out).at("flutes"))
    later += static_cast<int>(f.at("findings").size());
  EXPECT_EQ(later, 0);
  std::ifstream png(dir + "/overlay.png", std::ios::binary);
  char magic[4] = {};
  png.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  // Images that are not there: bad input.
  EXPECT_EQ(RunProcess(kMlp + " tool measure --images /nonexistent --tool " + tools +
                       "endmill_d10_z4_new.json")
                .exit_code,
            2);
}

}  // namespace
