// Camera + MEMS projector calibration end to end, as a user runs it: the virtual probe (an
// as-built probe, off its design by assembly tolerances) renders 16 chessboard views with
// `mlp-sim render`, the firmware extracts stripe centres with `mlp-fw stripes`, and
// `mlp calibrate camera` / `mlp calibrate projector` write the camera file and the probe model.
// Judged by what matters (issue 5: 5 um RMS): true surface points over the working volume seen
// by the true probe, triangulated with the written model, after the rigid alignment that the
// hand-eye absorbs (the probe frame is what calibration defines; only the shape of what it
// measures must be right).

#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/triangulate.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "calib/as_built_truth.h"
#include "calib/probe_truth.h"
#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test::RunProcess;

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
const std::string kAsBuilt = mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.json";
const std::string kAsBuiltCalibrated =
    mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.calibrated.json";
const std::string kBoardScene = mlp::test::SourceDir() + "/samples/calib/board_scene.json";
const std::string kRenderViews = mlp::test::SourceDir() + "/samples/calib/render_board_views.sh";
const std::string kSim = mlp::test::Program("mlp-sim"),
                  kMlp = mlp::test::Program("mlp");  // mlp-fw: beside mlp-sim
constexpr int kViews = 16;                           // the sample scene's captures
constexpr double kTriangulationRmsTolMm = 0.005;     // issue 5
constexpr double kFocalRelTol = 0.001;  // camera-only focal length vs truth: 0.1 % (~5 px)
constexpr double kCentreTolPx = 12.0;   // principal point: ~3 sigma of 16 views with this lens

// Renders the sample board views seen by the as-built probe into `dir` with the sample script a
// user runs (every view of the sample board scene, stripes beside); returns the truth.
void RenderViewsWith(const std::string& probe_file, const fs::path& dir) {
  const auto r = RunProcess("bash " + kRenderViews + " " + probe_file + " " + dir.string() + " " +
                            fs::path(kSim).parent_path().string());
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
}

probe_fw::ProbeModel RenderViews(const fs::path& dir) {
  fs::remove_all(dir);
  fs::create_directories(dir);
  const probe_fw::ProbeModel truth = test::AsBuilt(probe_fw::LoadProbeModel(kReference));
  probe_fw::SaveProbeModel(truth, (dir / "as_built.json").string());
  RenderViewsWith((dir / "as_built.json").string(), dir);
  return truth;
}

void CheckProjectorCommand(const fs::path& dir, const probe_fw::ProbeModel& truth) {
  const std::string views = (dir / "views.json").string();
  const std::string out = (dir / "calibrated.json").string();
  fs::remove(out);
  const auto run = RunProcess(kMlp + " calibrate projector --json --views " + views + " --design " +
                              kReference + " --out " + out + " --id cal-test-1");
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.err.find("joint adjustment"), std::string::npos) << "progress on stderr";
  const json summary = json::parse(run.out);
  EXPECT_EQ(summary.at("corners_used").get<int>(), kViews * 9 * 6);  // every board found
  const probe_fw::ProbeModel m = probe_fw::LoadProbeModel(out);
  EXPECT_EQ(m.calibration_id, "cal-test-1");
  EXPECT_EQ(m.serial, truth.serial);
  ASSERT_TRUE(m.calibration_stats.present);
  EXPECT_EQ(m.calibration_stats.views, kViews);
  EXPECT_EQ(m.calibration_stats.stripe_points, summary.at("stripe_points").at("used").get<int>());

  const test::TriangulationError e = test::TriangulationVsTruth(truth, m);
  const probe_fw::ProbeModel design = probe_fw::LoadProbeModel(kReference);
  const test::TriangulationError design_error = test::TriangulationVsTruth(truth, design);
  std::printf(
      "%zu points over the working volume: %.2f um RMS, max %.2f um after rigid alignment "
      "(%.1f um before; design model %.1f um); corner RMS %.4f px, stripe RMS %.4f columns, "
      "%d stripe points used\n",
      e.points, e.rms_mm * 1e3, e.max_mm * 1e3, e.unaligned_rms_mm * 1e3,
      design_error.unaligned_rms_mm * 1e3, summary.at("corner_rms_px").get<double>(),
      summary.at("stripe_rms_columns").get<double>(),
      summary.at("stripe_points").at("used").get<int>());
  ASSERT_GT(e.points, 100u);
  EXPECT_LT(e.rms_mm, kTriangulationRmsTolMm);
  // The projector's position along its stripe is not observable and stays at the design value.
  EXPECT_EQ(m.projector.camera_from_projector.translation().y(),
            design.projector.camera_from_projector.translation().y());

  // Calibrations are never overwritten.
  const auto again = RunProcess(kMlp + " calibrate projector --views " + views + " --design " +
                                kReference + " --out " + out);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("never overwritten"), std::string::npos) << again.err;
  EXPECT_EQ(probe_fw::LoadProbeModel(out).calibration_id, "cal-test-1");
}

void CheckCameraCommand(const fs::path& dir, const probe_fw::ProbeModel& truth) {
  const std::string views = (dir / "views.json").string();
  const std::string out = (dir / "camera.json").string();
  fs::remove(out);
  const auto run = RunProcess(kMlp + " calibrate camera --views " + views + " --out " + out);
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  EXPECT_NE(run.out.find("board found in 16 of 16 views"), std::string::npos) << run.out;
  std::ifstream in(out);
  const json j = json::parse(in);
  EXPECT_EQ(j.at("format"), "mlprobe-camera/1");
  EXPECT_EQ(j.at("views").size(), static_cast<size_t>(kViews));
  const json& k = j.at("intrinsics");
  std::printf("camera-only: fx %.2f (truth %.2f), fy %.2f (%.2f), cx %.2f (%.2f), cy %.2f (%.2f)\n",
              k.at("fx_px").get<double>(), truth.camera.fx_px, k.at("fy_px").get<double>(),
              truth.camera.fy_px, k.at("cx_px").get<double>(), truth.camera.cx_px,
              k.at("cy_px").get<double>(), truth.camera.cy_px);
  EXPECT_NEAR(k.at("fx_px").get<double>() / truth.camera.fx_px, 1.0, kFocalRelTol);
  EXPECT_NEAR(k.at("fy_px").get<double>() / truth.camera.fy_px, 1.0, kFocalRelTol);
  EXPECT_NEAR(k.at("cx_px").get<double>(), truth.camera.cx_px, kCentreTolPx);
  EXPECT_NEAR(k.at("cy_px").get<double>(), truth.camera.cy_px, kCentreTolPx);
  EXPECT_LT(j.at("rms_reprojection_px").get<double>(), 0.1);
}

// One run of the rendering (45 s) serves both commands: ctest runs each TEST in its own process.
TEST(CalibrateOptics, CameraAndProjectorCommandsFromRenderedViews) {
  const fs::path dir = fs::temp_directory_path() / "mlp_calibrate_optics";
  const probe_fw::ProbeModel truth = RenderViews(dir);
  ASSERT_FALSE(HasFailure());
  CheckProjectorCommand(dir, truth);
  CheckCameraCommand(dir, truth);
}

// Issue 16, part 1: the probe as built (samples/probes/as_built/MLP-AB-0001.json: off its design,
// a mirror's cubic of 1.5 columns, a smile of 0.6 columns at the fan's edge, and a 2 mm window
// no model describes), seen only through rendered views, calibrated from the design like any
// probe. The target holds (5 um RMS over the working volume), the mirror's cubic is
// found to 0.1 column; the smile, of which the camera sees only the middle third of the fan
// (0.07 column at the field's edge), to 0.15 column at the fan's edge.
constexpr double kBetterThanTheDesign = 10.0;
constexpr double kCubicTolCols = 0.1;
constexpr double kSmileTolCols = 0.15;

TEST(CalibrateOptics, AnAsBuiltProbeWithItsOpticsThroughTheCalibration) {
  const fs::path dir = fs::temp_directory_path() / "mlp_calibrate_optics_as_built";
  fs::remove_all(dir);
  fs::create_directories(dir);
  RenderViewsWith(kAsBuilt, dir);
  ASSERT_FALSE(HasFailure());
  const std::string out = (dir / "calibrated.json").string();
  const auto run =
      RunProcess(kMlp + " calibrate projector --json --views " + (dir / "views.json").string() +
                 " --design " + kReference + " --out " + out + " --id cal-as-built-1");
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const json summary = json::parse(run.out);
  const sim::AsBuiltProbe truth = sim::LoadAsBuilt(kAsBuilt);
  const probe_fw::ProbeModel calibrated = probe_fw::LoadProbeModel(out);
  const test::TriangulationError e = test::TriangulationVsAsBuilt(truth, calibrated);
  const test::TriangulationError design =
      test::TriangulationVsAsBuilt(truth, probe_fw::LoadProbeModel(kReference));
  const test::TriangulationError exact = test::TriangulationVsAsBuilt(truth, truth.model);
  std::printf(
      "as built with optics, %zu points over the working volume after rigid alignment: "
      "calibrated %.2f um RMS, max %.2f um (mirror cubic %.3f, smile %.3f columns); the as-built "
      "model itself, blind to the window only, %.2f um RMS, max %.2f um; the design %.2f um RMS; "
      "corner RMS %.4f px, stripe RMS %.4f columns\n",
      e.points, e.rms_mm * 1e3, e.max_mm * 1e3, calibrated.projector.mirror_cubic_cols,
      calibrated.projector.sheet_smile_cols, exact.rms_mm * 1e3, exact.max_mm * 1e3,
      design.rms_mm * 1e3, summary.at("corner_rms_px").get<double>(),
      summary.at("stripe_rms_columns").get<double>());
  ASSERT_GT(e.points, 100u);
  EXPECT_LT(e.rms_mm, kTriangulationRmsTolMm);
  EXPECT_LT(e.rms_mm * kBetterThanTheDesign, design.rms_mm);
  EXPECT_NEAR(calibrated.projector.mirror_cubic_cols, truth.model.projector.mirror_cubic_cols,
              kCubicTolCols);
  EXPECT_NEAR(calibrated.projector.sheet_smile_cols, truth.model.projector.sheet_smile_cols,
              kSmileTolCols);
  EXPECT_TRUE(summary.at("notes").empty()) << summary.at("notes").dump();
  // The calibrated sample the demo's firmware triangulates with is this chain's output from
  // these views (render_board_views.sh with the as-built sample, mlp calibrate projector): the
  // two models put every point of the working volume at the same place.
  constexpr double kSameModelMm = 1e-4;
  const probe_fw::ProbeModel sample = probe_fw::LoadProbeModel(kAsBuiltCalibrated);
  EXPECT_EQ(sample.calibration_id, "cal-as-built-1");
  double worst_mm = 0.0;
  for (double u = 200; u <= 1800; u += 400) {
    for (double w = 200; w <= 1400; w += 300) {
      for (double column = 300; column <= 700; column += 100) {
        worst_mm = std::max(worst_mm, (probe_fw::Triangulate(sample, u, w, column).value() -
                                       probe_fw::Triangulate(calibrated, u, w, column).value())
                                          .norm());
      }
    }
  }
  EXPECT_LT(worst_mm, kSameModelMm) << "samples/probes/as_built/MLP-AB-0001.calibrated.json is "
                                       "not what the chain makes now: regenerate it (PROBE.md)";
}

TEST(CalibrateOptics, UnusableViewsAreRefusedWithTheReason) {
  // A view without its stripe file: the projector cannot run, and says what to do.
  const fs::path bad = fs::temp_directory_path() / "mlp_calibrate_optics_bad";
  fs::remove_all(bad);
  fs::create_directories(bad);
  const auto view = RunProcess(kSim + " render --probe " + kReference + " --scene " + kBoardScene +
                               " --capture view01 --aoi full --column-count 2 --out " +
                               (bad / "view01").string() + " --noiseless");
  ASSERT_EQ(view.exit_code, 0) << view.err;
  std::ofstream(bad / "views.json") << json{
      {"format", "mlprobe-board-views/1"},
      {"board", {{"inner_cols", 9}, {"inner_rows", 6}, {"square_mm", 2.5}}},
      {"views", {"view01"}}}.dump();
  const std::string out = (bad / "model.json").string();
  auto r = RunProcess(kMlp + " calibrate projector --views " + (bad / "views.json").string() +
                      " --design " + kReference + " --out " + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("mlp-fw stripes"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out));
  // One view is not enough for a camera.
  r = RunProcess(kMlp + " calibrate camera --views " + (bad / "views.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("at least 4"), std::string::npos) << r.err;
  // A window of the sensor is not a calibration view.
  const auto partial = RunProcess(kSim + " render --probe " + kReference + " --scene " +
                                  kBoardScene + " --capture view01 --column-count 2 --out " +
                                  (bad / "view01").string() + " --noiseless");
  ASSERT_EQ(partial.exit_code, 0) << partial.err;
  r = RunProcess(kMlp + " calibrate camera --views " + (bad / "views.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("whole sensor"), std::string::npos) << r.err;
  // Wrong format, unknown option.
  EXPECT_EQ(RunProcess(kMlp + " calibrate camera --views " + kReference).exit_code, 2);
  EXPECT_EQ(RunProcess(kMlp + " calibrate camera --views x --frobnicate").exit_code, 2);
}

}  // namespace
}  // namespace mlp
