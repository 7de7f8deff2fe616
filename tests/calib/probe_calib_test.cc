// The camera/projector adjustment on its own, on exact synthetic observations of an as-built
// probe (fast; the rendered end-to-end run through the commands is
// tests/host/calibrate_optics_test.cc): accuracy of the triangulation, the unobservable
// projector offset held, and refusals of data that cannot determine the model.

#include "mlp/calib/probe_calib.h"

#include <random>

#include "calib/probe_truth.h"
#include "seeded_draw.h"
#include "test_data.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
constexpr double kTriangulationRmsTolMm = 0.005;  // issue 5
constexpr double kCornerNoisePx = 0.05;           // what the rendered views show (0.042)
constexpr double kStripeNoisePx = 0.05;
constexpr int kViews = 12;
constexpr int kStripesPerView = 800;
const ChessboardSpec kBoard{9, 6, 2.5};

Intrinsics IntrinsicsOf(const probe_fw::ProbeModel& m) {
  const auto& c = m.camera;
  return {c.fx_px, c.fy_px, c.cx_px, c.cy_px, c.k1, c.k2, c.p1, c.p2, c.k3};
}

std::vector<Pose3> BoardPoses() {
  std::vector<Pose3> out;
  const Vec3 half(0.5 * (kBoard.inner_cols + 1) * kBoard.square_mm,
                  0.5 * (kBoard.inner_rows + 1) * kBoard.square_mm, 0);
  for (int v = 0; v < kViews; ++v) {
    const double a = 0.6 * std::sin(1.7 * v), c = 0.55 * std::cos(2.3 * v);
    Pose3 p = Pose3::Identity();
    p.linear() = (Eigen::AngleAxisd(M_PI, Vec3::UnitX()) * Eigen::AngleAxisd(a, Vec3::UnitY()) *
                  Eigen::AngleAxisd(c, Vec3::UnitX()))
                     .toRotationMatrix();
    const Vec3 centre(9.0 * std::sin(2.9 * v), 7.0 * std::cos(1.1 * v),
                      125.0 + 10.0 * std::sin(0.9 * v));
    p.translation() = centre - p.linear() * half;
    out.push_back(p);
  }
  return out;
}

struct Synthetic {
  ProbeCalibInput input;
  std::vector<Pose3> truth_poses;
};

// Corners and stripe points the true probe would see, with noise; starts: the design camera and
// projector, board poses 0.5 mm / 0.01 rad off.
Synthetic Observe(const probe_fw::ProbeModel& truth, const probe_fw::ProbeModel& design) {
  std::mt19937 rng(5);
  std::normal_distribution<double> corner_noise(0, kCornerNoisePx), stripe_noise(0, kStripeNoisePx);
  std::uniform_real_distribution<double> on_board_x(0, (kBoard.inner_cols + 1) * kBoard.square_mm),
      on_board_y(0, (kBoard.inner_rows + 1) * kBoard.square_mm);
  const Intrinsics k = IntrinsicsOf(truth);
  Synthetic s;
  s.truth_poses = BoardPoses();
  auto& in = s.input;
  in.board = kBoard;
  in.camera_start = IntrinsicsOf(design);
  in.projector_start = {design.projector.f_px, design.projector.c_px,
                        design.projector.camera_from_projector};
  const ProjectorParams proj{truth.projector.f_px, truth.projector.c_px,
                             truth.projector.camera_from_projector};
  for (int v = 0; v < kViews; ++v) {
    const Pose3& pose = s.truth_poses[static_cast<size_t>(v)];
    std::vector<Vec2> corners;
    for (int j = 1; j <= kBoard.inner_rows; ++j)
      for (int i = 1; i <= kBoard.inner_cols; ++i)
        corners.push_back(k.Project(pose * Vec3(i * kBoard.square_mm, j * kBoard.square_mm, 0)) +
                          test::DrawVec2(corner_noise, rng));
    in.corners.push_back(corners);
    for (int n = 0; n < kStripesPerView; ++n) {
      const double y = on_board_y(rng);  // y drawn first: tests/seeded_draw.h
      const double x = on_board_x(rng);
      const Vec3 p = pose * Vec3(x, y, 0);
      const Vec2 px = k.Project(p);
      const double column = proj.ColumnOf(p);
      if (px.x() < 0 || px.y() < 0 || px.x() > truth.camera.width_px ||
          px.y() > truth.camera.height_px || column < 0 || column > truth.projector.columns - 1)
        continue;
      in.stripes.push_back({v, px.x() + stripe_noise(rng), px.y(), column});
    }
    Pose3 start = pose;
    start.translation() += Vec3(0.5, -0.5, 0.5);
    start.linear() = Eigen::AngleAxisd(0.01, Vec3(1, 1, 0).normalized()) * start.linear();
    in.camera_from_board_start.push_back(start);
  }
  return s;
}

TEST(ProbeCalibration, AdjustmentRecoversTheAsBuiltProbe) {
  const probe_fw::ProbeModel design = probe_fw::LoadProbeModel(kReference);
  const probe_fw::ProbeModel truth = test::AsBuilt(design);
  const Synthetic s = Observe(truth, design);
  const ProbeCalibResult r = AdjustCameraAndProjector(s.input);
  const probe_fw::ProbeModel m = CalibratedProbeModel(design, r, "synthetic-1");
  const double rms = test::TriangulationVsTruth(truth, m).rms_mm;
  std::printf(
      "synthetic: %d corners, %d stripe points; corner RMS %.4f px, stripe RMS %.4f "
      "columns; triangulation %.2f um RMS after rigid alignment\n",
      r.corners_used, r.stripes_used, r.corner_rms_px, r.stripe_rms_columns, rms * 1e3);
  EXPECT_LT(rms, kTriangulationRmsTolMm);
  EXPECT_EQ(r.views_used, kViews);
  EXPECT_NEAR(r.corner_rms_px, kCornerNoisePx, 0.3 * kCornerNoisePx);
  // The projector's position along its stripe direction changes no light plane: held at start.
  EXPECT_EQ(r.projector.camera_from_projector.translation().y(),
            design.projector.camera_from_projector.translation().y());
  EXPECT_EQ(m.calibration_id, "synthetic-1");
  EXPECT_EQ(m.calibration_stats.stripe_points, r.stripes_used);
}

TEST(ProbeCalibration, RefusesDataThatCannotDetermineTheModel) {
  const probe_fw::ProbeModel design = probe_fw::LoadProbeModel(kReference);
  Synthetic s = Observe(test::AsBuilt(design), design);
  ProbeCalibInput no_stripes = s.input;
  no_stripes.stripes.clear();
  EXPECT_THROW(AdjustCameraAndProjector(no_stripes), CameraCalibError);
  ProbeCalibInput three_boards = s.input;
  for (size_t v = 3; v < three_boards.corners.size(); ++v) three_boards.corners[v].clear();
  EXPECT_THROW(AdjustCameraAndProjector(three_boards), CameraCalibError);
  ProbeCalibInput wrong_poses = s.input;
  wrong_poses.camera_from_board_start.pop_back();
  EXPECT_THROW(AdjustCameraAndProjector(wrong_poses), CameraCalibError);
  // A stripe file naming a view that is not there.
  const GrayImage blank{64, 48, 8, std::vector<std::uint16_t>(64 * 48, 0)};
  EXPECT_THROW(CalibrateProbe({blank}, {{3, 10, 10, 100}}, kBoard, design), CameraCalibError);
}

TEST(ProbeCalibration, StripePointsOnlyOnUniformLight) {
  // Left half dark (a black square), right half light: a stripe window reaching the edge would
  // be pulled towards the light side.
  GrayImage img{100, 10, 8, std::vector<std::uint16_t>(1000, 0)};
  for (int y = 0; y < 10; ++y)
    for (int x = 50; x < 100; ++x) img.pixels[static_cast<size_t>(y * 100 + x)] = 200;
  EXPECT_TRUE(OnUniformLight(img, 70.0, 5));
  EXPECT_FALSE(OnUniformLight(img, 55.0, 5));  // the edge is 5 px away: inside +-8 px
  EXPECT_FALSE(OnUniformLight(img, 20.0, 5));  // dark
  EXPECT_FALSE(OnUniformLight(img, 95.0, 5));  // the window leaves the image
  EXPECT_FALSE(OnUniformLight(img, 70.0, 12));
}

}  // namespace
}  // namespace mlp::calib
