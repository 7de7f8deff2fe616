// `mlp history spc` as a real process on a real SQLite history: a bore measured on 40 parts by
// the measure job's record (its reply's size and error, its request's tolerance), a drawing
// change half way (another nominal: another characteristic), the figures against the SPC
// module's own on the same values, the run chart's SVG, and the exit codes.

#include "mlp/features/spc.h"
#include "mlp/history/history.h"

#include <filesystem>
#include <random>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::RunProcess;
const std::string kMlp = test::Program("mlp");
constexpr double kSame = 1e-9;  // figures through JSON text (17 digits)

// One measure job as mlp-hostd records it: the reply's size and error, the request's tolerance.
void Measured(history::History* h, double nominal, double size, history::JobStatus status) {
  const json request = {{"op", "measure"},
                        {"feature", "bore"},
                        {"tolerance", {{"upper_mm", 0.02}, {"lower_mm", 0.01}}}};
  const auto id = h->StartJob({"vmc-1", "measure", "MLP-1", "MLP-1-he-7", request});
  const json reply = {{"size_mm", size}, {"error_mm", size - nominal}};
  h->AddResult(id, {"bore", reply, {{"verdict", "in tolerance"}}});
  h->FinishJob(id, status, reply, json::object());
}

TEST(HistorySpc, ABoresCapabilityFromTheHistory) {
  const fs::path dir = fs::temp_directory_path() / "mlp_history_spc";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string db = (dir / "history.sqlite").string();
  std::vector<double> first, second;
  {
    history::History h(db);
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.003);
    for (int i = 0; i < 30; ++i) {
      first.push_back(40.004 + noise(rng));
      Measured(&h, 40.0, first.back(), history::JobStatus::kInTolerance);
    }
    const auto refused = h.StartJob({"vmc-1", "measure", "MLP-1", "", json::object()});
    h.AddResult(refused, {"bore", {{"size_mm", 99.0}, {"error_mm", 59.0}}, json::object()});
    h.FinishJob(refused, history::JobStatus::kRefused, json::object(), json::object());
    for (int i = 0; i < 10; ++i) {  // the drawing changed: D42
      second.push_back(42.001 + noise(rng));
      Measured(&h, 42.0, second.back(), history::JobStatus::kInTolerance);
    }
  }
  const std::string spc = kMlp + " history spc --db " + db + " --feature bore";
  const auto run = RunProcess(spc + " --json --svg " + (dir / "bore.svg").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json j = json::parse(run.out);
  ASSERT_EQ(j.size(), 2u);  // two characteristics, the refused job's figure in neither
  const features::CapabilityStudy a = features::StudyCapability(first, {39.99, 40.02});
  EXPECT_EQ(j[0].at("n"), 30);
  EXPECT_NEAR(j[0].at("nominal").get<double>(), 40.0, kSame);
  EXPECT_NEAR(j[0].at("mean").get<double>(), a.mean, kSame);
  EXPECT_NEAR(j[0].at("cpk").get<double>(), a.cpk, kSame);
  EXPECT_NEAR(j[0].at("ppk").get<double>(), a.ppk, kSame);
  EXPECT_EQ(j[1].at("n"), 10);
  EXPECT_TRUE(j[1].at("few_values").get<bool>());
  EXPECT_TRUE(fs::exists(dir / "bore.svg"));
  EXPECT_TRUE(fs::exists(dir / "bore-2.svg"));
  std::printf("spc: D40 n %d mean %.5f Cp %.2f Cpk %.2f Ppk %.2f\n", a.n, a.mean, a.cp, a.cpk,
              a.ppk);
  // The last 10 parts: only the new drawing's.
  const auto last = RunProcess(spc + " --last 10");
  ASSERT_EQ(last.exit_code, 0) << last.err;
  EXPECT_NE(last.out.find("nominal 42.0000 mm"), std::string::npos) << last.out;
  EXPECT_EQ(last.out.find("nominal 40.0000"), std::string::npos) << last.out;
  EXPECT_NE(last.out.find("Cpk"), std::string::npos) << last.out;
  EXPECT_NE(last.out.find("fewer than 25 parts"), std::string::npos) << last.out;
  // No such feature: 3; no --feature or no database: 2.
  EXPECT_EQ(RunProcess(kMlp + " history spc --db " + db + " --feature slot").exit_code, 3);
  EXPECT_EQ(RunProcess(kMlp + " history spc --db " + db).exit_code, 2);
  EXPECT_EQ(
      RunProcess(kMlp + " history spc --db " + (dir / "none.sqlite").string() + " --feature bore")
          .exit_code,
      2);
}

}  // namespace
}  // namespace mlp
