// Every feature of the features block end to end, as a macro runs them, through the product's
// chain: the hand-eye calibrated on the reference sphere, then the host plans each feature's
// captures from its nominal (op plan: flange poses, AOI, projector columns) with the calibrated
// model, the virtual probe renders them as built through the firmware (given the calibration
// only) and the authenticated link, the host measures; each result against the scene's truth
// (samples/scenes/features_block.json).

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "hostd_site.h"
#include "test_data.h"

namespace mlp::test {
namespace {

constexpr int kInspectPort = 17439;  // this test's probe link
const std::string kFeaturesBlock = mlp::test::SourceDir() + "/samples/scenes/features_block.json";
constexpr double kSizeTolMm = 0.002;          // issue 6: sizes within 2 um (as the bore)
constexpr double kPositionTolMm = 0.005;      // positions within 5 um (as the alignment origin)
constexpr double kAngleTolDeg = 10.0 / 3600;  // angles within 10 arcsec
constexpr double kSurfaceMeanTolMm = 0.001;   // the curvature bias of a 0.5 mm nominal grid

// Each truth value against the reply's: positions (arrays) and sizes in mm, angles in deg.
void CheckAgainstTruth(const std::string& feature, const json& truth, const json& reply) {
  for (const auto& [key, want] : truth.items()) {
    ASSERT_TRUE(reply.contains(key)) << feature << ": no " << key << " in " << reply.dump();
    const json& got = reply.at(key);
    if (want.is_array()) {
      double worst = 0;
      for (size_t k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(got[k].get<double>() - want[k].get<double>()));
      std::printf("  %-12s %-14s off by %.2f um\n", feature.c_str(), key.c_str(), worst * 1e3);
      EXPECT_LT(worst, kPositionTolMm) << feature << " " << key;
      continue;
    }
    const double error = got.get<double>() - want.get<double>();
    const bool deg = key.size() > 4 && key.substr(key.size() - 4) == "_deg";
    std::printf("  %-12s %-14s %.5f, off by %.2f %s\n", feature.c_str(), key.c_str(),
                got.get<double>(), deg ? error * 3600 : error * 1e3, deg ? "arcsec" : "um");
    const double tol = deg ? kAngleTolDeg : (key == "mean_mm" ? kSurfaceMeanTolMm : kSizeTolMm);
    EXPECT_LT(std::abs(error), tol) << feature << " " << key;
  }
}

TEST(Inspect, PlansCapturesAndMeasuresEveryFeatureOfTheBlock) {
  // Through the product's chain (issue 16): the probe renders as built, the firmware and the
  // host know only its calibration, and the hand-eye is calibrated first on the reference sphere.
  Site site("inspect", kInspectPort);
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["probes"][0]["model_file"] = kCalibratedModel;
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  CalibrateThroughChain(site, "vmc-1", kInspectPort);
  if (HasFatalFailure()) return;
  Child probe(AsBuiltProbeArgs(site, kFeaturesBlock, kInspectPort), site.dir / "sim.log");
  ASSERT_TRUE(ProbeConnected(site));
  const json inspection = json::parse(ReadText(kFeaturesBlock)).at("inspection");
  ASSERT_EQ(inspection.size(), 8u);
  for (const json& f : inspection) {
    const std::string feature = f.at("feature");
    json plan_request = {
        {"op", "plan"}, {"machine", "vmc-1"}, {"feature", feature}, {"nominal", f.at("nominal")}};
    if (f.contains("views_per_circle")) plan_request["views_per_circle"] = f["views_per_circle"];
    const json plan = RequestOn(site, feature + "-plan", plan_request);
    ASSERT_TRUE(plan.contains("captures")) << feature;
    const auto captures = TakePlan(site, "vmc-1", feature, plan);
    ASSERT_EQ(captures.size(), plan.at("captures").size()) << feature;
    json measure = f;
    measure.erase("truth"), measure.erase("views_per_circle");
    measure["op"] = "measure", measure["machine"] = "vmc-1", measure["captures"] = captures;
    // The boss also sets up G55 on its centre: the work offset moves by where it was found.
    if (feature == "boss") measure["update_work"] = {{"offset", 2}, {"axes", "xy"}};
    const json reply = RequestOn(site, feature + "-measure", measure);
    std::printf("%s: %zu planned captures, status %s\n", feature.c_str(), captures.size(),
                reply.value("status", "?").c_str());
    EXPECT_EQ(reply.value("status", ""), "in_tolerance") << feature << ": " << reply.dump();
    CheckAgainstTruth(feature, f.at("truth"), reply);
    if (feature == "surface") {  // the form alone: a best fit takes the 4 um proud place out
      json form = measure;
      form["nominal"]["best_fit"] = true;
      const json fitted = RequestOn(site, "surface-form", form);
      ASSERT_TRUE(fitted.contains("best_fit")) << fitted.dump();
      const double mean = fitted.at("mean_mm");
      std::printf(
          "  surface      best fit: mean %.2f um, profile %.2f um (as placed %.2f um), "
          "%zu motions it cannot fix\n",
          mean * 1e3, fitted.at("profile_mm").get<double>() * 1e3,
          reply.at("profile_mm").get<double>() * 1e3,
          fitted.at("best_fit").at("not_determined").size());
      EXPECT_LT(std::abs(mean), kSurfaceMeanTolMm);
      EXPECT_LE(fitted.at("profile_mm").get<double>(), reply.at("profile_mm").get<double>());
    }
    // The operator's picture: the feature's name, the verdict and its surfaces.
    ASSERT_TRUE(reply.contains("report")) << feature;
    const std::string svg = ReadText(reply.at("report").get<std::string>());
    EXPECT_NE(svg.find(" - " + feature + " - vmc-1"), std::string::npos) << feature;
    EXPECT_NE(svg.find("in tolerance"), std::string::npos) << feature;
    EXPECT_GT(std::count(svg.begin(), svg.end(), '\n'), 100) << feature << ": no points drawn";
    if (feature == "boss") {
      const json truth = f.at("truth").at("centre_mm"),
                 nominal = f.at("nominal").at("top_centre_mm");
      for (int k = 0; k < 2; ++k)
        EXPECT_NEAR(reply.at("update_work").at("shift_mm")[k].get<double>(),
                    truth[k].get<double>() - nominal[k].get<double>(), kPositionTolMm);
      EXPECT_EQ(reply.at("update_work").at("shift_mm")[2].get<double>(), 0.0);  // xy only
      std::printf("  boss         G55 shift      (%.2f, %.2f) um\n",
                  reply.at("update_work").at("shift_mm")[0].get<double>() * 1e3,
                  reply.at("update_work").at("shift_mm")[1].get<double>() * 1e3);
    }
  }
}

}  // namespace
}  // namespace mlp::test
