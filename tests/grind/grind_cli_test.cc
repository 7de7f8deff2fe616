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
  EXPECT_EQ(RunProcess(kMlp + " grind measure").exit_code, 2);
}

}  // namespace
