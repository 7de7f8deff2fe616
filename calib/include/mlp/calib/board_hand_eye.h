#pragma once
/// @file Hand-eye from a fixed chessboard (issue 18), beside the sphere method (hand_eye.h): the
/// camera's mounting X = flange_from_camera and the board's pose B = base_from_board from images
/// at known flange poses F_i.
///   1. start: AX = XB from the board poses and the robot poses (Park & Martin, "Robot sensor
///      calibration: solving AX = XB on the Euclidean group", IEEE T-RA 1994; OpenCV);
///   2. one least-squares problem (Ceres, Huber loss at 3 sigma) over X, B, the light plane
///      and each image's robot error D_i (the true flange pose is F_i D_i; errors-in-variables):
///        corner residual = projection of B's corner through X^-1 D_i^-1 F_i^-1 - detected  [px]
///        laser residual  = height above the board of the stripe pixel's ray met with the
///                          light plane, mapped by F_i D_i X                                [mm]
///        robot residual  = D_i's rotation [rad] and translation [mm], zero expected
///      each divided by its class's noise. The sensor's classes are independent point by point;
///      a robot's pose error is one per image and moves all its corners and laser points
///      together, so it gets its own unknowns instead of being taken for pixel noise (which, on
///      a synthetic cell with 0.05 mm of robot noise, put X 0.5 mm off while AX = XB was
///      0.1 mm off; with it, 0.09 mm on average). The noise of every class starts from the
///      calibration (for the robot's translation: the corners' spread through the start, which
///      also caps it) and is then estimated from the solution until it settles (variance
///      components, Helmert / Foerstner 1979; robust scales for the sensor's classes); the
///      robot's rotation noise is given (BoardHandEyeOptions). Images without a board (dark
///      laser shots) add laser residuals only.
/// Observability as the sphere method reports it: X's covariance at the solution, rotations
/// turned into lengths with a lever arm; a combination above the limit is refused.

#include "mlp/calib/hand_eye.h"
#include "mlp/calib/line_laser.h"
#include "mlp/calib/robot_views.h"

#include <string>
#include <vector>

#include <Eigen/Core>

namespace mlp::calib {

struct BoardHandEyeOptions {
  double lever_mm = 100.0;   ///< rotations as lengths at this distance (about the stand-off)
  double max_std_mm = 0.05;  ///< a combination of X less well determined is refused
  bool refine_plane = true;  ///< the light plane free in the joint problem
  int max_laser_points_per_image = 400;  ///< evenly thinned beyond
  /// The robot's orientation error per pose, 1 sigma per axis [deg]: given, not estimated (its
  /// translation error is). 0.01 deg is a small six-axis arm's (UR5e class).
  double robot_rotation_sigma_deg = 0.01;
};

struct BoardHandEyeImage {
  std::string name;
  int corners = 0, laser_points = 0;
  double corner_rms_px = 0.0;                     ///< through X, B and F_i
  double laser_rms_mm = 0.0, laser_max_mm = 0.0;  ///< heights above the board
  /// The robot's pose error the fit gave this image (0 for an image not used).
  double robot_error_mm = 0.0, robot_error_deg = 0.0;
};

struct BoardHandEyeResult {
  geometry::Pose3 flange_from_camera = geometry::Pose3::Identity();        ///< X
  geometry::Pose3 base_from_board = geometry::Pose3::Identity();           ///< B
  geometry::Pose3 start_flange_from_camera = geometry::Pose3::Identity();  ///< AX = XB
  geometry::Plane plane;  ///< the light plane in the camera frame after the joint fit
  /// X's covariance: rotation vector in the flange frame [rad], translation [mm].
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  double worst_std_mm = 0.0;  ///< the least determined combination, rotations at the lever arm
  double corner_rms_px = 0.0;
  int corners_used = 0, laser_points_used = 0, iterations = 0;
  /// The classes' noise the last pass weighed with: the sensor's corners [px] and laser
  /// heights [mm], the robot's pose error per image [mm], [deg] (1 sigma per axis).
  double corner_sigma_px = 0.0, laser_sigma_mm = 0.0;
  double robot_sigma_mm = 0.0, robot_sigma_deg = 0.0;
  int variance_passes = 0;  ///< joint solves until the class weights settled
  std::vector<BoardHandEyeImage> images;
  std::vector<std::string> warnings;
};

/// `calibration` from CalibrateLineLaser on the same findings; `images[i]` is the pose of
/// `findings[i]`. Throws HandEyeError (kBadInput: fewer than 3 board views; kUnderDetermined).
BoardHandEyeResult SolveBoardHandEye(const std::vector<ImageFindings>& findings,
                                     const std::vector<RobotImage>& images,
                                     const LineLaserCalibration& calibration,
                                     const ChessboardSpec& board,
                                     const BoardHandEyeOptions& options = {});

/// Every stripe point of image i in the robot's base frame: the ray met with the light plane,
/// mapped by F_i X [mm].
std::vector<geometry::Vec3> LaserPointsInBase(const ImageFindings& findings,
                                              const geometry::Pose3& base_from_flange,
                                              const Intrinsics& camera,
                                              const geometry::Plane& plane_in_camera,
                                              const geometry::Pose3& flange_from_camera);

/// One image checked against a calibration held fixed (issue 52: a check a user runs on a new
/// image): the board's pose as the image shows it (PnP with the calibration's camera) against
/// the pose the calibration expects (B seen through F_i X), and the laser points' heights above
/// each. Above the seen board they test the camera and the light plane alone (no robot pose,
/// no hand-eye); above the expected one, the whole chain.
struct BoardImageCheck {
  geometry::Pose3 camera_from_board_seen = geometry::Pose3::Identity();
  double seen_corner_rms_px = 0.0;      ///< the corners through the seen pose
  double expected_corner_rms_px = 0.0;  ///< the corners through F_i X and B
  /// The seen board's middle against the expected one's, in the base [mm], and the turn
  /// between the two poses [deg]: the robot's pose error, or a moved board, or a stale X.
  double board_offset_mm = 0.0, board_turn_deg = 0.0;
  /// Laser points kept: within 2.5 robust sigma (and 0.1 mm) of the seen board's plane; those
  /// beyond (light beside the board, on the table or the clamp) are left out and counted, and
  /// the heights over all points given beside.
  int laser_points = 0, laser_left_out = 0;
  double laser_left_out_beyond_mm = 0.0;
  double laser_all_rms_mm = 0.0, laser_all_max_mm = 0.0;    ///< above the seen board, all
  double laser_seen_rms_mm = 0.0, laser_seen_max_mm = 0.0;  ///< heights above the seen board
  double laser_expected_mean_mm = 0.0, laser_expected_rms_mm = 0.0,
         laser_expected_max_mm = 0.0;  ///< heights above B
};

/// Throws CameraCalibError when the image shows no board.
BoardImageCheck CheckBoardImage(const ImageFindings& findings,
                                const geometry::Pose3& base_from_flange,
                                const Intrinsics& camera,
                                const geometry::Plane& plane_in_camera,
                                const geometry::Pose3& flange_from_camera,
                                const geometry::Pose3& base_from_board,
                                const ChessboardSpec& board);

/// RMS and largest of distances [mm].
struct Spread {
  double rms_mm = 0.0, max_mm = 0.0;  ///< over the points kept
  int points = 0;
  int outliers = 0;  ///< left out (SpreadAboutCommonPlane)
  /// SpreadAboutCommonPlane: the rule that left them out (beyond threshold_mm of the plane),
  /// the same figures over every point, and the plane (for each point's distance).
  double threshold_mm = 0.0;
  double all_rms_mm = 0.0, all_max_mm = 0.0;
  geometry::Plane plane;
};
/// How far points lie from their common plane: MSAC + trimming (geometry/robust.h), so laser
/// light on the table beside the board (another plane) is counted as outliers, not spread;
/// the all-points figures beside them (a summary says what it left out).
Spread SpreadAboutCommonPlane(const std::vector<geometry::Vec3>& points);

/// Each board corner mapped to the base through each view's own board pose (camera_from_board,
/// from the camera calibration), F_i and X: its spread about its mean over the views [mm].
Spread CornerSpreadInBase(const std::vector<geometry::Pose3>& camera_from_board,
                          const std::vector<geometry::Pose3>& base_from_flange,
                          const geometry::Pose3& flange_from_camera,
                          const ChessboardSpec& board);

}  // namespace mlp::calib
