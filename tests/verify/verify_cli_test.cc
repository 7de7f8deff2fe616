// `mlp verify` as a real process (issue 16, part 4): the acceptance test in the manner of ISO
// 10360-8, shortened (--quick), through the product's chain: the virtual probe renders as built
// (samples/probes/as_built/MLP-AB-0001.json) with a lens of f/4.8 and speckle of contrast 0.3
// (grains of 1.5 px), the firmware and the host know it only through its calibration, the
// hand-eye is calibrated on a matt sphere first. Matt coated and ground steel.

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

using mlp::test::RunProcess;
using nlohmann::json;
const std::string kMlp = mlp::test::Program("mlp");

// Issue 16, done means, end to end through calibration: under speckle of C 0.3 with grains of
// 1.5 px the clouds <= 10 um RMS; a bore's diameter <= 2 um on a matt face and <= 5 um on ground
// steel, held here for the test sphere's diameter (P_Size.Sph.All). The hand-eye's 5 um is held
// by the demo's test; here it is reported (docs/ACCURACY.md: its truth is known only to the
// calibrated frame's non-rigidity) and its effect is in E_Uni, which must be within its MPE.
constexpr double kCloudRmsUm = 10.0;
constexpr double kMattSizeUm = 2.0;
constexpr double kSteelSizeUm = 5.0;
// A probing view reads the sphere's cap to 65 deg (a 530-620 px window) every second column:
// 70,000-90,000 points.
constexpr int kMinViewPoints = 50000;

const json* FindTest(const json& finish, const std::string& name) {
  for (const json& t : finish.at("tests"))
    if (t.at("test") == name) return &t;
  return nullptr;
}

TEST(VerifyCli, QuickAcceptanceThroughTheCalibratedChainMeetsTheIssueFigures) {
  const std::string svg = "/tmp/mlp_verify_cli_test.svg";
  std::remove(svg.c_str());
  const auto run = RunProcess(
      kMlp + " verify --quick --f-number 4.8 --speckle-contrast 0.3 --json" + " --svg " + svg);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;  // every figure within the declared MPEs
  const json r = json::parse(run.out);
  for (const json& f : r.at("finishes")) {
    std::printf("%s:", f.at("material").get<std::string>().c_str());
    for (const json& t : f.at("tests"))
      std::printf(" %s %.2f um,", t.at("test").get<std::string>().c_str(),
                  t.at("value_um").get<double>());
    std::printf(" scatter %.2f um RMS\n", f.at("dispersion_rms_um").get<double>());
  }
  constexpr double kGrainTolPx = 0.05;  // the speckle grain the probe file says
  EXPECT_NEAR(r.at("probe").at("speckle_grain_px").get<double>(), 1.5, kGrainTolPx);
  EXPECT_LT(r.at("hand_eye").at("point_rms_um").get<double>(), kCloudRmsUm);  // its sphere clouds
  ASSERT_EQ(r.at("finishes").size(), 2u);
  for (const json& f : r.at("finishes")) {
    const std::string material = f.at("material");
    SCOPED_TRACE(material);
    ASSERT_EQ(f.at("views").size(), 2u);
    for (const json& v : f.at("views")) EXPECT_GT(v.at("points").get<int>(), kMinViewPoints);
    ASSERT_EQ(f.at("lengths").size(), 4u);  // 2 orientations x lengths 50 and 100 mm
    EXPECT_LT(f.at("dispersion_rms_um").get<double>(), kCloudRmsUm);
    const json* size = FindTest(f, "P_Size.Sph.All");
    ASSERT_NE(size, nullptr);
    EXPECT_LT(std::abs(size->at("value_um").get<double>()),
              material == "matt_coated" ? kMattSizeUm : kSteelSizeUm);
    for (const char* name : {"P_Form.Sph.1x25", "P_Form.Sph.D95%", "P_Size.Sph.1x25", "E_Uni"}) {
      const json* t = FindTest(f, name);
      ASSERT_NE(t, nullptr) << name;
      EXPECT_TRUE(std::isfinite(t->at("value_um").get<double>())) << name;
      EXPECT_TRUE(t->at("within").get<bool>()) << name;
    }
  }
  // The picture: one marker with its tooltip per length, both panels, the world said.
  std::ifstream in(svg);
  const std::string picture((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(picture.rfind("<svg", 0), 0u) << svg;
  size_t titles = 0;
  for (size_t at = picture.find("<title>"); at != std::string::npos;
       at = picture.find("<title>", at + 1))
    ++titles;
  EXPECT_EQ(titles, 8u);  // 2 finishes x 4 lengths
  for (const char* s : {"E_Uni", "probing form", "virtual machine", "ground_steel"})
    EXPECT_NE(picture.find(s), std::string::npos) << s;
}

TEST(VerifyCli, TheReadableSummaryNamesEveryTestAndItsWorld) {
  // The same run as text would take minutes again; the summary of an impossible MPE is enough to
  // see the text and the exit code of a figure beyond its MPE.
  const auto run = RunProcess(kMlp +
                              " verify --finish matt_coated:1 --hand-eye-views 6 --probing-views 1"
                              " --orientations 0 --mpe-form-um 0.001");
  EXPECT_EQ(run.exit_code, 3) << run.err;
  for (const char* s : {"virtual machine", "P_Form.Sph.1x25", "P_Form.Sph.D95%", "P_Size.Sph.All",
                        "P_Size.Sph.1x25", "BEYOND MPE", "hand-eye"})
    EXPECT_NE(run.out.find(s), std::string::npos) << s << " in\n" << run.out;
  EXPECT_NE(run.err.find("probing view 1/1"), std::string::npos) << run.err;  // progress
}

TEST(VerifyCli, BadArgumentsAndFilesAreRefusedBeforeAnythingIsRendered) {
  for (const char* args :
       {"--finish chrome", "--f-number 0.5", "--speckle-contrast 2", "--probing-views 0",
        "--orientations 8", "--spheres 1", "--mpe-form-um -1", "--mpe-length 5",
        "--finish ground_steel:0", "--probe /nonexistent/as_built.json", "--unknown", "--seed"}) {
    const auto run = RunProcess(kMlp + " verify " + args);
    EXPECT_EQ(run.exit_code, 2) << args << ": " << run.err;
    EXPECT_NE(run.err.find("mlp verify: "), std::string::npos) << args;
    EXPECT_EQ(run.err.find(" s] "), std::string::npos) << args << ": something was rendered";
  }
}

}  // namespace
