// The command sequence of docs/CALIBRATION.md for a camera with a fixed line laser on a robot,
// run as real processes on the real blaser images (../shared/data/blaser-line-laser; read in
// place): `mlp calibrate line-laser` -> `board-hand-eye` -> `map`, fitted on 24 of the 30
// images and checked on the 6 held out (every fifth image): their laser points, through the
// firmware's triangulation and the stored hand-eye, must lie on the one fixed board plane.
// No ground truth: the figures are the sensor's and the robot's, bounded at the measured value
// + ~20 %.

#include "mlp/probe_fw/cloud_file.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Measured on the 24 fitted images (line-laser, then the hand-eye with the plane refined):
constexpr double kCornerRmsPx = 0.6;  // measured 0.510 px (12 boards)
constexpr double kPlaneRmsMm = 0.08;  // measured 0.068 mm
// measured 0.193 mm (1 sigma, rotations at 100 mm); above the default limit of 0.2 mm the
// command refuses (exit 3)
constexpr double kWorstStdMm = 0.2;
constexpr double kFitLaserRmsMm = 0.35;  // measured 0.294 mm about one plane in the base
// The 6 held-out images' clouds about one common plane in the base frame (worse than the fitted
// images': they include im10, whose robot pose disagrees with the others by ~0.6 mm):
constexpr double kHeldOutRmsMm = 0.41;  // measured 0.338 mm
constexpr double kHeldOutMaxMm = 1.06;  // measured 0.880 mm

test::ProcessRun Mlp(const std::string& args) {
  return test::RunProcess(mlp::test::Program("mlp") + " calibrate " + args);
}

// The held-out manifest with one more image: im20 (a held-out laser close-up) exposed 3x as
// long (each channel x3, clipped at 255), at im20's pose, under the name im20_x3.png; the
// images linked into `dir`.
std::string OverExposedManifest(const fs::path& dir, const std::string& held_out) {
  const fs::path data = test::SharedDataDir() / "blaser-line-laser", images = dir / "images";
  fs::create_directories(images);
  for (const auto& e : fs::directory_iterator(data))
    if (e.path().extension() == ".png" && !fs::exists(images / e.path().filename()))
      fs::create_symlink(fs::absolute(e.path()), images / e.path().filename());
  cv::Mat bright;
  cv::imread((data / "im20.png").string(), cv::IMREAD_COLOR).convertTo(bright, -1, 3.0);
  cv::imwrite((images / "im20_x3.png").string(), bright);
  std::ifstream in(data / "data.txt");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (line.find_first_not_of(" \t\r") != std::string::npos) lines.push_back(line);
  std::ifstream held(held_out);
  json m = json::parse(held);
  std::ofstream poses(dir / "over_exposed.txt");
  std::ifstream held_poses(m["poses"]["file"].get<std::string>());
  poses << held_poses.rdbuf();
  for (size_t i = 0; i + 2 < lines.size(); i += 3)
    if (lines[i + 2] == "im20.png") poses << lines[i] << "\n" << lines[i + 1] << "\nim20_x3.png\n";
  m["images"] = images.string();
  m["poses"]["file"] = (dir / "over_exposed.txt").string();
  std::ofstream(dir / "over_exposed.json") << m.dump(1);
  return (dir / "over_exposed.json").string();
}

// A poses file of the images whose number satisfies `keep`, and a manifest for it.
std::string Manifest(const fs::path& dir, const std::string& name, bool held_out) {
  const fs::path data = test::SharedDataDir() / "blaser-line-laser";
  std::ifstream in(data / "data.txt");
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (line.find_first_not_of(" \t\r") != std::string::npos) lines.push_back(line);
  std::ofstream poses(dir / (name + ".txt"));
  for (size_t i = 0; i + 2 < lines.size(); i += 3)
    if (((i / 3) % 5 == 0) == held_out)
      poses << lines[i] << "\n" << lines[i + 1] << "\n" << lines[i + 2] << "\n";
  std::ifstream sample(mlp::test::SourceDir() + "/samples/robot/blaser_views.json");
  json m = json::parse(sample);
  m["images"] = fs::absolute(data).string();
  m["poses"]["file"] = (dir / (name + ".txt")).string();
  const fs::path path = dir / (name + ".json");
  std::ofstream(path) << m.dump(2);
  return path.string();
}

TEST(RobotViewsCli, LineLaserHandEyeAndMapOnHeldOutRealImages) {
  const fs::path dir = fs::temp_directory_path() / "mlp_robot_views_cli";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string fit = Manifest(dir, "fit", false), held = Manifest(dir, "held_out", true);
  const std::string design = mlp::test::SourceDir() + "/samples/probes/blaser_design.json";
  const std::string probe = (dir / "probe.json").string(),
                    refined = (dir / "refined.json").string();
  const std::string store = (dir / "store").string();

  const auto cal =
      Mlp("line-laser --json --views " + fit + " --design " + design + " --out " + probe);
  ASSERT_EQ(cal.exit_code, 0) << cal.err;
  const json c = json::parse(cal.out);
  std::printf("line-laser: %zu boards, corners %.3f px, stripe %.3f px, plane %.4f mm\n",
              c["boards_used"].get<size_t>(), c["corner_rms_px"].get<double>(),
              c["stripe_scatter_px"].get<double>(), c["plane"]["rms_mm"].get<double>());
  EXPECT_EQ(c["images"].size(), 24u);
  EXPECT_LT(c["corner_rms_px"].get<double>(), kCornerRmsPx);
  EXPECT_LT(c["plane"]["rms_mm"].get<double>(), kPlaneRmsMm);
  // Never overwritten: the same --out again is refused before any work.
  const auto again = Mlp("line-laser --views " + fit + " --design " + design + " --out " + probe);
  EXPECT_EQ(again.exit_code, 2) << again.err;

  const auto he = Mlp("board-hand-eye --json --views " + fit + " --probe " + probe + " --store " +
                      store + " --refined-probe " + refined);
  ASSERT_EQ(he.exit_code, 0) << he.err;
  const json h = json::parse(he.out);
  std::printf("hand-eye %s: worst %.4f mm, corners in base %.3f / %.3f mm, laser %.3f / %.3f mm\n",
              h["calibration_id"].get<std::string>().c_str(), h["worst_std_mm"].get<double>(),
              h["corner_spread_in_base"]["rms_mm"].get<double>(),
              h["corner_spread_in_base"]["max_mm"].get<double>(),
              h["laser_points_about_common_plane"]["rms_mm"].get<double>(),
              h["laser_points_about_common_plane"]["max_mm"].get<double>());
  EXPECT_TRUE(h["stored"].get<bool>());
  EXPECT_LT(h["worst_std_mm"].get<double>(), kWorstStdMm);
  EXPECT_LT(h["laser_points_about_common_plane"]["rms_mm"].get<double>(), kFitLaserRmsMm);
  // A stricter observability limit than the data supports: refused (exit 3), nothing stored.
  const auto strict = Mlp("board-hand-eye --max-std-mm 0.01 --views " + fit + " --probe " + probe +
                          " --store " + (dir / "strict_store").string());
  EXPECT_EQ(strict.exit_code, 3) << strict.err;
  EXPECT_FALSE(fs::exists(dir / "strict_store" / "BLASER-UR5E"));

  const fs::path clouds = dir / "clouds";
  const auto map = Mlp("map --json --views " + held + " --probe " + refined + " --store " + store +
                       " --out " + clouds.string());
  // Exit 5: the clouds are written and an image is flagged. Issue 52: the headline left out
  // 161 points unsaid; im25 holds 7 of them 46 mm off the board (stray light), now flagged by
  // name, and every figure is given over all points beside the kept ones.
  ASSERT_EQ(map.exit_code, 5) << map.err;
  const json m = json::parse(map.out);
  const json& s = m["points_about_common_plane"];
  std::printf(
      "held out: %d points about one plane %.3f / %.3f mm (%d left out beyond %.3f mm); "
      "all points %.3f / %.3f mm\n",
      s["points"].get<int>(), s["rms_mm"].get<double>(), s["max_mm"].get<double>(),
      s["outliers"].get<int>(), s["left_out_beyond_mm"].get<double>(),
      s["all_points"]["rms_mm"].get<double>(), s["all_points"]["max_mm"].get<double>());
  EXPECT_GE(s["all_points"]["max_mm"].get<double>(), s["max_mm"].get<double>());
  // im10's stripe is 41 % saturated (its red channel clipped on 884 pixels): flagged since the
  // firmware names a clipped flat top saturated before it calls it a double peak (it said 0 %).
  int flagged = 0, left_out = 0;
  for (const auto& e : m["images"]) {
    if (e.contains("refused")) continue;
    left_out += e["left_out"].get<int>();
    if (!e.contains("flag")) continue;
    ++flagged;
    const std::string why = e["flag"];
    if (e["name"] == "im10.png") {
      EXPECT_NE(why.find("% of the stripe saturated"), std::string::npos) << why;
      EXPECT_GT(e["saturated_share"].get<double>(), 0.25);
      continue;
    }
    EXPECT_EQ(e["name"], "im25.png") << e.dump();
    EXPECT_NE(why.find("mm off the plane"), std::string::npos);
  }
  EXPECT_EQ(flagged, 2);
  EXPECT_EQ(left_out, s["outliers"].get<int>());  // the images' counts add up to the summary's
  EXPECT_EQ(m["hand_eye_calibration_id"], h["calibration_id"]);
  EXPECT_LT(s["rms_mm"].get<double>(), kHeldOutRmsMm);
  EXPECT_LT(s["max_mm"].get<double>(), kHeldOutMaxMm);
  // Every held-out image is a cloud or refused with a reason; the clouds say their frame.
  ASSERT_EQ(m["images"].size(), 6u);
  for (const auto& e : m["images"]) {
    if (e.contains("refused")) {
      EXPECT_FALSE(e["refused"].get<std::string>().empty());
      continue;
    }
    // Each image's mean depth (the near-range bias is studied against it): the Blaser's
    // held-out images lie 60-130 mm from the camera (measured 63.6-124.9 mm).
    constexpr double kNearestMm = 40, kFarthestMm = 150;
    EXPECT_GT(e["depth_mm"].get<double>(), kNearestMm) << e.dump();
    EXPECT_LT(e["depth_mm"].get<double>(), kFarthestMm) << e.dump();
    const auto cloud = probe_fw::ReadCloudPly(e["cloud"].get<std::string>());
    EXPECT_EQ(cloud.meta.frame, "base");
    EXPECT_EQ(cloud.xyz.size(), 3 * e["points"].get<size_t>());
    EXPECT_TRUE(cloud.meta.mcs_from_flange.has_value());
  }
  // Issue 52: an over-exposed image (made: im20 at 3x its exposure) is flagged by name as
  // saturated, with the words an operator needs; the others' figures do not change.
  const auto over = Mlp("map --json --views " + OverExposedManifest(dir, held) + " --probe " +
                        refined + " --store " + store + " --out " + (dir / "over").string());
  ASSERT_EQ(over.exit_code, 5) << over.err;
  const json o = json::parse(over.out);
  bool saturated_flagged = false;
  for (const auto& e : o["images"]) {
    if (e["name"] != "im20_x3.png") continue;
    std::printf("im20 at 3x exposure: %s\n", e.dump().c_str());
    ASSERT_TRUE(e.contains("flag") || e.contains("refused")) << e.dump();
    const std::string why = e.contains("flag") ? e["flag"] : e["refused"];
    saturated_flagged = why.find("% of the stripe saturated") != std::string::npos;
    EXPECT_GT(e["saturated_share"].get<double>(), 0.5);
  }
  EXPECT_TRUE(saturated_flagged);
  // Issue 52: each held-out image's board pose with the calibration held fixed. im10, whose
  // robot pose disagrees with the others, is flagged by its corners (measured 8.6 px through
  // the calibration against the fit's 2.6; its board 0.71 mm from where it is put); the others
  // agree (their boards 0.10-0.24 mm off, the laser's mean on the calibrated board within
  // 0.5 mm); the images without a board are listed with the reason.
  const auto pose =
      Mlp("board-pose --json --views " + held + " --probe " + refined + " --store " + store);
  ASSERT_EQ(pose.exit_code, 5) << pose.err;
  constexpr double kAgreeingBoardMm = 0.3, kAgreeingLaserMeanMm = 0.56, kIm10BoardMm = 0.5;
  for (const auto& e : json::parse(pose.out)["images"]) {
    if (e.contains("refused")) {
      EXPECT_FALSE(e["refused"].get<std::string>().empty());
      continue;
    }
    EXPECT_LT(e["seen_corner_rms_px"].get<double>(), kCornerRmsPx) << e.dump();
    if (e["name"] == "im10.png") {
      ASSERT_TRUE(e.contains("flag")) << e.dump();
      EXPECT_NE(e["flag"].get<std::string>().find("corners sit"), std::string::npos);
      EXPECT_GT(e["board_offset_mm"].get<double>(), kIm10BoardMm);
      continue;
    }
    EXPECT_FALSE(e.contains("flag")) << e.dump();
    EXPECT_LT(e["board_offset_mm"].get<double>(), kAgreeingBoardMm) << e.dump();
    EXPECT_LT(std::abs(e["laser_above_calibrated_board"]["mean_mm"].get<double>()),
              kAgreeingLaserMeanMm);
  }
  // The clouds are never overwritten, and a MEMS probe's model is not a line laser.
  const auto twice = Mlp("map --views " + held + " --probe " + refined + " --store " + store +
                         " --out " + clouds.string());
  EXPECT_EQ(twice.exit_code, 2) << twice.err;
  const auto mems = Mlp("map --views " + held + " --probe " + mlp::test::SourceDir() +
                        "/samples/probes/reference_probe.json --store " + store + " --out " +
                        (dir / "mems").string());
  EXPECT_EQ(mems.exit_code, 2) << mems.err;
}

}  // namespace
}  // namespace mlp
