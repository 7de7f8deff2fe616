// The `mlp fit` contract, run as a real process on real files: JSON fields, exit codes, and
// nothing on stdout for bad input.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "seeded_draw.h"
#include "test_data.h"
#include <Eigen/Core>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

namespace {

struct CliRun {
  int exit_code;
  std::string out;
};

// Runs the mlp binary with a shell command line; stderr is discarded by the caller's redirect.
CliRun RunMlp(const std::string& args) {
  const std::string cmd = mlp::test::Program("mlp") + " " + args;
  FILE* pipe = popen(cmd.c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof(buf), pipe)) out.append(buf, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

std::filesystem::path TempFile(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("mlp_cli_test_" + name);
  std::ofstream(path) << text;
  return path;
}

TEST(FitCli, SphereFromXyzTextGivesContractFields) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g(0.0, 1.0), noise(0.0, 0.001);
  std::string text = "# reference sphere, r = 12.7 mm at (100, -50, 20)\n";
  for (int i = 0; i < 500; ++i) {
    Eigen::Vector3d d = mlp::test::DrawVec3(g, rng);
    d.z() = std::abs(d.z());
    d.normalize();
    const Eigen::Vector3d p = Eigen::Vector3d(100, -50, 20) + (12.7 + noise(rng)) * d;
    text +=
        std::to_string(p.x()) + " " + std::to_string(p.y()) + "\t" + std::to_string(p.z()) + "\n";
  }
  const auto path = TempFile("sphere.xyz", text);
  const CliRun r = RunMlp("fit sphere " + path.string());
  ASSERT_EQ(r.exit_code, 0);
  const auto j = nlohmann::json::parse(r.out);
  constexpr double kSphereTolMm = 0.001;  // noise 1 um
  EXPECT_NEAR(j["radius"].get<double>(), 12.7, kSphereTolMm);
  EXPECT_NEAR(j["center"][0].get<double>(), 100.0, kSphereTolMm);
  EXPECT_EQ(j["n"].get<int>(), 500);
  for (const char* key : {"rms", "min", "max", "std_dev", "units"})
    EXPECT_TRUE(j.contains(key)) << key;
}

TEST(FitCli, EveryShapeAndMethodOnRealOrSyntheticFiles) {
  const auto pcd = mlp::test::RepoDataDir() / "pcl" / "sac_plane_test.pcd";
  const CliRun plane = RunMlp("fit plane --method robust --units m " + pcd.string());
  ASSERT_EQ(plane.exit_code, 0);
  const auto j = nlohmann::json::parse(plane.out);
  EXPECT_TRUE(j.contains("normal") && j.contains("point") && j.contains("inliers"));
  const CliRun flat = RunMlp("fit plane --method minzone --units m " + pcd.string());
  ASSERT_EQ(flat.exit_code, 0);
  EXPECT_GT(nlohmann::json::parse(flat.out)["flatness"].get<double>(), 0.0);
  // A circle in a tilted plane through stdin, by every circle method.
  std::string text;
  for (int i = 0; i < 72; ++i) {
    const double t = 2 * M_PI * i / 72;
    text += std::to_string(5 + 10 * std::cos(t)) + " " + std::to_string(10 * std::sin(t)) + " " +
            std::to_string(0.1 * std::cos(t) + 0.002 * std::cos(3 * t)) + "\n";
  }
  const auto circle = TempFile("circle.xyz", text);
  for (const char* method : {"ls", "robust", "minzone", "mic", "mcc"}) {
    const CliRun r =
        RunMlp(std::string("fit circle --method ") + method + " - < " + circle.string());
    ASSERT_EQ(r.exit_code, 0) << method;
    const auto c = nlohmann::json::parse(r.out);
    EXPECT_NEAR(c["radius"].get<double>(), 10.0, 0.01) << method;
    EXPECT_TRUE(c.contains("center") && c.contains("normal")) << method;
  }
}

// The circle's two definitions by name, and the minimum zones of a sphere and a cylinder with
// three lobes of 2 um (r = R + A cos 3 phi at every latitude / height, the extremes sampled):
// both zones are exactly 2 A, to the 1 nm the text files carry.
TEST(FitCli, CircleDefinitionsAndFormZones) {
  constexpr double kLobeMm = 0.002, kFileRoundingMm = 1e-5;
  std::string ring, ball, shaft;
  for (int i = 0; i < 72; ++i) {
    const double t = 2 * M_PI * i / 72;
    ring += std::to_string(5 + 10 * std::cos(t)) + " " + std::to_string(10 * std::sin(t)) + " " +
            std::to_string(0.02 * std::cos(2 * t)) + "\n";
    for (int k = -4; k <= 4; ++k) {
      const double r = 10.0 + kLobeMm * std::cos(3 * t), lat = 0.3 * k;
      ball += std::to_string(r * std::cos(lat) * std::cos(t)) + " " +
              std::to_string(r * std::cos(lat) * std::sin(t)) + " " +
              std::to_string(r * std::sin(lat)) + "\n";
      shaft += std::to_string(r * std::cos(t)) + " " + std::to_string(r * std::sin(t)) + " " +
               std::to_string(5.0 * k) + "\n";
    }
  }
  const auto ring_file = TempFile("ring.xyz", ring);
  for (const char* definition : {"spatial", "plane-then-circle"}) {
    const CliRun r =
        RunMlp(std::string("fit circle --circle3 ") + definition + " " + ring_file.string());
    ASSERT_EQ(r.exit_code, 0) << definition << r.out;
    EXPECT_EQ(nlohmann::json::parse(r.out)["definition"], definition);
  }
  const CliRun sphere =
      RunMlp("fit sphere --method minzone " + TempFile("ball.xyz", ball).string());
  ASSERT_EQ(sphere.exit_code, 0) << sphere.out;
  EXPECT_NEAR(nlohmann::json::parse(sphere.out)["sphericity"].get<double>(), 2 * kLobeMm,
              kFileRoundingMm);
  const CliRun cyl =
      RunMlp("fit cylinder --method minzone " + TempFile("shaft.xyz", shaft).string());
  ASSERT_EQ(cyl.exit_code, 0) << cyl.out;
  EXPECT_NEAR(nlohmann::json::parse(cyl.out)["cylindricity"].get<double>(), 2 * kLobeMm,
              kFileRoundingMm);
  // The definition is a circle's only, and one of the two.
  EXPECT_EQ(RunMlp("fit plane --circle3 spatial " + ring_file.string() + " 2>/dev/null").exit_code,
            2);
  EXPECT_EQ(RunMlp("fit circle --circle3 nist " + ring_file.string() + " 2>/dev/null").exit_code,
            2);
}

TEST(FitCli, BadInputExitsTwoWithNothingOnStdout) {
  const auto collinear = TempFile("collinear.xyz", "0 0 0\n1 1 1\n2 2 2\n3 3 3\n");
  const auto nan = TempFile("nan.xyz", "0 0 0\n1 0 0\n0 1 0\nabc 1 1\n");
  const auto two = TempFile("two.xyz", "0 0 0\n1 0 0\n");
  for (const std::string& args :
       {"fit plane " + collinear.string(), "fit plane " + nan.string(),
        "fit sphere " + two.string(), std::string("fit plane /no/such/file.xyz"),
        "fit torus " + two.string(), "fit sphere --method minzone " + two.string(),
        std::string("fit"), "fit plane --units furlong " + two.string(), std::string("nonsense")}) {
    const CliRun r = RunMlp(args + " 2>/dev/null");
    EXPECT_EQ(r.exit_code, 2) << args;
    EXPECT_TRUE(r.out.empty()) << args << " printed: " << r.out;
  }
}

}  // namespace
