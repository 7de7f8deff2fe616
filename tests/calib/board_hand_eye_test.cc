// The board hand-eye against ground truth (issue 18): a camera with a fixed line laser on a
// robot, looking at a fixed chessboard, made here from known X = flange_from_camera,
// B = base_from_board, camera and light plane, with noise on the corners and stripe centres and
// on the robot's poses. The chain (CalibrateLineLaser, SolveBoardHandEye) must find X within
// its own reported uncertainty, and refuse views that cannot determine it. The real images'
// figures are in blaser_test.cc; this world knows its truth, those do not.

#include "mlp/calib/board_hand_eye.h"

#include "mlp/calib/line_laser.h"
#include "mlp/probe_fw/probe_model.h"

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

#include "seeded_draw.h"
#include "test_data.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

constexpr double kCornerNoisePx = 0.3;   // 1 sigma, the blaser's corner RMS is 0.5 px
constexpr double kStripeNoisePx = 0.3;   // 1 sigma across the line
constexpr double kRobotNoiseMm = 0.05;   // 1 sigma per axis of the flange position
constexpr double kRobotNoiseDeg = 0.01;  // 1 sigma of the flange orientation
constexpr unsigned kSeeds = 8;
// Measured over the 8 seeds with the camera known: 0.076-0.143 mm, 0.036-0.116 deg; the robot's
// noise (0.05 mm, 0.01 deg per view, 9 board views) sets it.
constexpr double kTranslationTolMm = 0.2;
constexpr double kRotationTolDeg = 0.15;
constexpr double kPlaneTiltTolDeg = 0.1;
// The translation's errors over the reported sigmas, RMS over the 24 components of 8 seeds:
// 1 for an honest uncertainty. Measured 1.64: the robot's noise is estimated from its
// shrunk per-image errors (0.015-0.028 mm against 0.037 mm true, rotations at the lever).
constexpr double kSigmaRatioMax = 2.0;
constexpr double kFxSigmas = 3.0;  // the camera calibration's own focal length error, in its sigmas
constexpr double kChainTranslationTolMm = 1.0;  // measured 0.745 mm (the camera's focal length)

const ChessboardSpec kBoard{9, 6, 5.0};

Pose3 Turn(const Vec3& axis_angle_deg, const Vec3& t) {
  Pose3 p = Pose3::Identity();
  const double a = axis_angle_deg.norm();
  if (a > 0) p.linear() = Eigen::AngleAxisd(a * M_PI / 180, axis_angle_deg / a).toRotationMatrix();
  p.translation() = t;
  return p;
}

struct World {
  Intrinsics camera{1000, 1000, 640, 480, -0.1, 0.05, 0, 0, 0};
  geometry::Plane plane{Vec3(0, 0, 100), Vec3(0, 0.94, 0.34).normalized()};  // camera frame
  Pose3 x = Turn(Vec3(2, -1, 91), Vec3(100.7, -16.6, 0.3));                  // flange_from_camera
  Pose3 b = Turn(Vec3(0, 180, 0), Vec3(400, -20, 3));                        // base_from_board
};

// Camera poses looking at the board's centre from ~100 mm: tilted up to 25 degrees about two
// axes and turned about the line of sight by up to 60 degrees (`two_axes`), or tilted about one
// axis only (a set that cannot determine the mounting).
std::vector<Pose3> CameraPoses(bool two_axes) {
  std::vector<Pose3> out;
  const Vec3 centre(25, 17.5, 0);
  for (int i = 0; i < 12; ++i) {
    const double a = -25 + 50.0 * i / 11;
    const Eigen::Matrix3d tilt =
        two_axes
            ? (Eigen::AngleAxisd((-60 + 120.0 * ((5 * i) % 12) / 11) * M_PI / 180, Vec3::UnitZ()) *
               Eigen::AngleAxisd(a * M_PI / 180, Vec3::UnitY()) *
               Eigen::AngleAxisd(20 * std::sin(1.7 * i) * M_PI / 180, Vec3::UnitX()))
                  .toRotationMatrix()
            : Eigen::AngleAxisd(a * M_PI / 180, Vec3::UnitY()).toRotationMatrix();
    Pose3 board_from_camera = Pose3::Identity();
    board_from_camera.linear() = tilt;
    board_from_camera.translation() = centre - tilt * Vec3(0, 0, 100 + 3 * (i % 3));
    out.push_back(board_from_camera.inverse());  // camera_from_board
  }
  return out;
}

struct Views {
  std::vector<ImageFindings> findings;
  std::vector<RobotImage> images;
};

// Stripe centres: the light plane met with the board plane, projected, every 4 px.
void AddStripe(const World& w,
               const Pose3& camera_from_board,
               std::mt19937& rng,
               ImageFindings* f) {
  std::normal_distribution<double> noise(0.0, kStripeNoisePx);
  const Vec3 n_board = camera_from_board.linear().col(2);
  const double d_board = n_board.dot(camera_from_board.translation());
  const Vec3 dir = n_board.cross(w.plane.normal).normalized();
  // A point on both planes: least-norm solution of the two plane equations.
  Eigen::Matrix<double, 2, 3> a;
  a.row(0) = n_board.transpose(), a.row(1) = w.plane.normal.transpose();
  const Vec3 p0 = a.transpose() * (a * a.transpose()).inverse() *
                  Eigen::Vector2d(d_board, w.plane.normal.dot(w.plane.point));
  for (double s = -80; s <= 80; s += 0.4) {
    const Vec3 p = p0 + s * dir;
    const Vec3 on_board = camera_from_board.inverse() * p;
    if (on_board.x() < -5 || on_board.x() > 55 || on_board.y() < -5 || on_board.y() > 40) continue;
    const Vec2 px = w.camera.Project(p);
    if (px.x() < 0 || px.x() > 1279 || px.y() < 0 || px.y() > 959) continue;
    f->stripe_px.push_back(px + Vec2(0, noise(rng)));
    f->stripe_quality.push_back(1.0f);
  }
}

Views Observe(const World& w, bool two_axes, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> px(0.0, kCornerNoisePx), mm(0.0, kRobotNoiseMm),
      deg(0.0, kRobotNoiseDeg);
  Views v;
  const auto poses = CameraPoses(two_axes);
  for (size_t i = 0; i < poses.size(); ++i) {
    ImageFindings f;
    f.name = "v";  // (not "v" + to_string: gcc 12's false -Wrestrict at -O3)
    f.name += std::to_string(i);
    f.width_px = 1280, f.height_px = 960, f.corner_scale = 1.0;
    const bool dark = i % 4 == 3;  // a laser shot without the board, as the blaser's im12-22
    for (int r = 1; r <= kBoard.inner_rows && !dark; ++r)
      for (int c = 1; c <= kBoard.inner_cols; ++c)
        f.corners.push_back(w.camera.Project(poses[i] * Vec3(c * 5.0, r * 5.0, 0)) +
                            test::DrawVec2(px, rng));
    AddStripe(w, poses[i], rng, &f);
    // The flange pose the robot reports: the true one, off by the robot's error.
    const Pose3 flange = w.b * poses[i].inverse() * w.x.inverse();
    const Vec3 error_mm = test::DrawVec3(mm, rng);  // before the angles: tests/seeded_draw.h
    const Vec3 error_deg = test::DrawVec3(deg, rng);
    const Pose3 error = Turn(error_deg, error_mm);
    v.images.push_back({f.name, f.name, flange * error});
    v.findings.push_back(std::move(f));
  }
  return v;
}

probe_fw::ProbeModel TrueProbe(const World& w) {
  return LineLaserProbeModel(
      probe_fw::LoadProbeModel(mlp::test::SourceDir() + "/samples/probes/blaser_design.json"),
      w.camera, w.plane, "truth");
}

struct Errors {
  double t_mm = 0, r_deg = 0, start_t_mm = 0;
};

Errors ErrorsOf(const World& w, const BoardHandEyeResult& r) {
  const Pose3 d = w.x.inverse() * r.flange_from_camera;
  return {(r.flange_from_camera.translation() - w.x.translation()).norm(),
          Eigen::AngleAxisd(d.linear()).angle() * 180 / M_PI,
          (r.start_flange_from_camera.translation() - w.x.translation()).norm()};
}

// The camera known (its board poses by PnP, as `mlp calibrate board-hand-eye` does with a probe
// file): the hand-eye alone, over eight seeds.
TEST(BoardHandEye, FindsTheMountingWithinItsReportedUncertainty) {
  const World w;
  const probe_fw::ProbeModel truth = TrueProbe(w);
  double sum_joint = 0, sum_start = 0, normalized2 = 0;
  int normalized = 0;
  for (unsigned seed = 1; seed <= kSeeds; ++seed) {
    const Views v = Observe(w, true, seed);
    const LineLaserCalibration cal = LineLaserOfModel(v.findings, truth, kBoard);
    BoardHandEyeOptions o;
    o.max_std_mm = 0.2;
    const BoardHandEyeResult r = SolveBoardHandEye(v.findings, v.images, cal, kBoard, o);
    const Errors e = ErrorsOf(w, r);
    std::printf(
        "seed %u: X off by %.4f mm, %.4f deg (worst 1-sigma %.4f mm; AX = XB %.4f mm); "
        "noise: corners %.3f px, laser %.4f mm, robot %.4f mm %.4f deg, %d passes\n",
        seed, e.t_mm, e.r_deg, r.worst_std_mm, e.start_t_mm, r.corner_sigma_px, r.laser_sigma_mm,
        r.robot_sigma_mm, r.robot_sigma_deg, r.variance_passes);
    EXPECT_LT(e.t_mm, kTranslationTolMm) << "seed " << seed;
    EXPECT_LT(e.r_deg, kRotationTolDeg) << "seed " << seed;
    // The reported covariance against the truth: the translation's errors in reported sigmas.
    for (int k = 0; k < 3; ++k) {
      const double d = r.flange_from_camera.translation()(k) - w.x.translation()(k);
      normalized2 += d * d / r.covariance(3 + k, 3 + k), ++normalized;
    }
    // The light plane stays the true one.
    EXPECT_LT(std::acos(std::min(1.0, std::abs(r.plane.normal.dot(w.plane.normal)))) * 180 / M_PI,
              kPlaneTiltTolDeg);
    sum_joint += e.t_mm, sum_start += e.start_t_mm;
  }
  // On average the joint fit beats AX = XB alone (not seed by seed: measured 0.08-0.14 mm
  // against 0.04-0.24 mm).
  EXPECT_LT(sum_joint, sum_start);
  // An honest uncertainty gives errors of 1 reported sigma RMS.
  const double ratio = std::sqrt(normalized2 / normalized);
  std::printf("translation errors in reported sigmas: %.2f RMS over %d components\n", ratio,
              normalized);
  EXPECT_LT(ratio, kSigmaRatioMax);
}

// The whole chain: the camera calibrated from the same corners first. Its error (a focal
// length 0.6 % off at seed 7: 9 views of a small board) moves X by as much; the hand-eye's
// reported uncertainty does not include it (docs/CALIBRATION.md says so).
TEST(BoardHandEye, TheChainWithTheCameraCalibratedFromTheSameViews) {
  const World w;
  const Views v = Observe(w, true, 7);
  const LineLaserCalibration cal = CalibrateLineLaser(v.findings, kBoard, 1280, 960);
  BoardHandEyeOptions o;
  o.max_std_mm = 0.2;
  const BoardHandEyeResult r = SolveBoardHandEye(v.findings, v.images, cal, kBoard, o);
  const Errors e = ErrorsOf(w, r);
  const double fx_off = cal.camera.intrinsics.fx_px - w.camera.fx_px;
  std::printf("chain: fx %.2f px off (reported 1-sigma %.2f px); X off by %.4f mm, %.4f deg\n",
              fx_off, cal.camera.std_dev.fx_px, e.t_mm, e.r_deg);
  EXPECT_LT(std::abs(fx_off), kFxSigmas * cal.camera.std_dev.fx_px);
  EXPECT_LT(e.t_mm, kChainTranslationTolMm);
}

TEST(BoardHandEye, ViewsTurnedAboutOneAxisAreRefused) {
  const World w;
  const Views v = Observe(w, false, 8);
  const LineLaserCalibration cal = LineLaserOfModel(v.findings, TrueProbe(w), kBoard);
  BoardHandEyeOptions o;
  o.max_std_mm = 0.2;
  try {
    SolveBoardHandEye(v.findings, v.images, cal, kBoard, o);
    ADD_FAILURE() << "views turned about one axis determine no mounting";
  } catch (const HandEyeError& e) {
    EXPECT_EQ(e.kind(), HandEyeError::Kind::kUnderDetermined) << e.what();
  }
}

// One image checked with the calibration held fixed (issue 52's single-image check), on the
// synthetic cell whose truth is known: with the true calibration the board is where it is put
// (within the corners' noise through PnP) and the laser on it; with the board moved 1 mm along
// its x and the robot's error left out, the check reports the move.
TEST(BoardHandEye, OneImageCheckedAgainstACalibrationHeldFixed) {
  const World w;
  const Views v = Observe(w, true, 11);
  const ImageFindings& f = v.findings[0];
  const Pose3 flange = w.b * CameraPoses(true)[0].inverse() * w.x.inverse();  // no robot error
  const BoardImageCheck same = CheckBoardImage(f, flange, w.camera, w.plane, w.x, w.b, kBoard);
  std::printf("same: %.4f mm %.4f deg corners %.3f / %.3f px laser %d mean %.4f mm\n",
              same.board_offset_mm, same.board_turn_deg, same.seen_corner_rms_px,
              same.expected_corner_rms_px, same.laser_points, same.laser_expected_mean_mm);
  // Measured 0.044 mm, 0.046 deg, corners 0.42 / 0.43 px (0.3 px a coordinate), the laser's
  // mean -0.003 mm over 144 points: PnP on 54 corners from ~100 mm, one seed.
  constexpr double kSameOffsetMm = 0.1, kSameTurnDeg = 0.1, kLaserMeanMm = 0.02;
  EXPECT_LT(same.board_offset_mm, kSameOffsetMm);
  EXPECT_LT(same.board_turn_deg, kSameTurnDeg);
  EXPECT_LT(same.seen_corner_rms_px, 2 * kCornerNoisePx);
  EXPECT_LT(same.expected_corner_rms_px, 2 * kCornerNoisePx);
  EXPECT_GT(same.laser_points, 100);
  EXPECT_LT(std::abs(same.laser_expected_mean_mm), kLaserMeanMm);
  const Pose3 moved = w.b * Turn(Vec3::Zero(), Vec3(1.0, 0, 0));  // the board 1 mm along its x
  const BoardImageCheck off = CheckBoardImage(f, flange, w.camera, w.plane, w.x, moved, kBoard);
  constexpr double kMoveTolMm = 0.06;
  EXPECT_NEAR(off.board_offset_mm, 1.0, kMoveTolMm);
  EXPECT_GT(off.expected_corner_rms_px, 5.0);  // 1 mm at ~100 mm with f = 1000 px: ~10 px
  ImageFindings none = f;
  none.corners.clear();
  EXPECT_THROW(CheckBoardImage(none, flange, w.camera, w.plane, w.x, w.b, kBoard),
               CameraCalibError);
}

}  // namespace
}  // namespace mlp::calib
