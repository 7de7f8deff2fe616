// `mlp grind` as real processes: a sweep rendered to files, measured from them into JSON and
// a picture, against the sweep's truth; a job that is not one is bad input.

#include <filesystem>
#include <fstream>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

using mlp::test::RunProcess;
const std::string kMlp = mlp::test::Program("mlp");
constexpr double kDTolMm = 0.001;

TEST(GrindCli, RendersAndMeasuresASweepIntoCompensations) {
  const std::string dir = "/tmp/mlp_grind_cli";
  std::filesystem::remove_all(dir);
  const auto render = RunProcess(kMlp + " grind render --out " + dir + " --cases 4 --seed 11");
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const auto run = RunProcess(kMlp + " grind measure --job " + dir + "/job.json --png " + dir +
                              "/plot.png --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto got = nlohmann::json::parse(run.out).at("points");
  std::ifstream in(dir + "/truth.json");
  const auto truth = nlohmann::json::parse(in).at("points");
  ASSERT_EQ(got.size(), 4u);
  for (size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].at("feed"), truth[i].at("feed")) << "point " << i;
    EXPECT_NEAR(got[i].at("d_mm").get<double>(), truth[i].at("d_mm").get<double>(), kDTolMm);
  }
  std::ifstream png(dir + "/plot.png", std::ios::binary);
  char magic[4] = {};
  png.read(magic, 4);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  const auto text = RunProcess(kMlp + " grind measure --job " + dir + "/job.json");
  EXPECT_NE(text.out.find("4 points:"), std::string::npos) << text.out;
  EXPECT_EQ(RunProcess(kMlp + " grind measure --job " + dir + "/truth.json").exit_code, 2);
  // A double-bevel wheel: the job carries it, the measurement follows it.
  const std::string bevel = dir + "/bevel";
  ASSERT_EQ(
      RunProcess(kMlp + " grind render --out " + bevel + " --cases 2 --bevel-deg 35").exit_code, 0);
  const auto job = nlohmann::json::parse(mlp::test::ReadText(bevel + "/job.json"));
  EXPECT_EQ(job.at("bevel").at("half_angle_deg"), 35.0);
  const auto bevel_run = RunProcess(kMlp + " grind measure --job " + bevel + "/job.json --json");
  ASSERT_EQ(bevel_run.exit_code, 0) << bevel_run.err;
  const auto bevel_truth =
      nlohmann::json::parse(mlp::test::ReadText(bevel + "/truth.json")).at("points");
  const auto bevel_got = nlohmann::json::parse(bevel_run.out).at("points");
  ASSERT_EQ(bevel_got.size(), 2u);
  for (size_t i = 0; i < bevel_got.size(); ++i) {
    EXPECT_EQ(bevel_got[i].at("feed"), bevel_truth[i].at("feed")) << "point " << i;
    EXPECT_NEAR(bevel_got[i].at("d_mm").get<double>(), bevel_truth[i].at("d_mm").get<double>(),
                kDTolMm);
  }
  EXPECT_EQ(RunProcess(kMlp + " grind render --out " + bevel + " --bevel-deg 95").exit_code, 2);
  EXPECT_EQ(RunProcess(kMlp + " grind measure").exit_code, 2);
}

}  // namespace
