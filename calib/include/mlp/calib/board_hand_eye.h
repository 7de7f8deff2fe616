#pragma once
/// @file Hand-eye from a fixed chessboard (issue 18), beside the sphere method (hand_eye.h): the
/// camera's mounting X = flange_from_camera and the board's pose B = base_from_board from images
/// at known flange poses F_i.
///   1. start: AX = XB from the board poses and the robot poses (Park & Martin, "Robot sensor
///      calibration: solving AX = XB on the Euclidean group", IEEE T-RA 1994; OpenCV);
///   2. one least-squares problem (Ceres, Huber loss at 3 sigma) over X, B and the light plane:
///        corner residual = projection of B's corner through X^-1 F_i^-1 - detected corner  [px]
///        laser residual  = height above the board of the stripe pixel's ray met with the
///                          light plane, mapped by F_i X                                     [mm]
///      each divided by its class's noise, so pixels and millimetres weigh by their own: first
///      the calibration's (the sensor's alone), then, until they settle, the robust scale of
///      each class's residuals at the solution, which carries the robot's pose error too
///      (variance components, Helmert / Foerstner 1979). Weighing corners by the sensor's
///      0.5 px when the robot puts them 3 px off made every corner a Huber outlier and the
///      fit an L1 one that let a view's error (im10 of the blaser data) through to the
///      corners' spread. Images without a board (dark laser shots) add laser residuals only.
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
};

struct BoardHandEyeImage {
  std::string name;
  int corners = 0, laser_points = 0;
  double corner_rms_px = 0.0;                     ///< through X, B and F_i
  double laser_rms_mm = 0.0, laser_max_mm = 0.0;  ///< heights above the board
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
  /// The classes' noise the last pass weighed with: sensor and robot together [px], [mm].
  double corner_sigma_px = 0.0, laser_sigma_mm = 0.0;
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

/// RMS and largest of distances [mm].
struct Spread {
  double rms_mm = 0.0, max_mm = 0.0;
  int points = 0;
  int outliers = 0;  ///< left out (SpreadAboutCommonPlane)
};
/// How far points lie from their common plane: MSAC + trimming (geometry/robust.h), so laser
/// light on the table beside the board (another plane) is counted as outliers, not spread.
Spread SpreadAboutCommonPlane(const std::vector<geometry::Vec3>& points);

/// Each board corner mapped to the base through each view's own board pose (camera_from_board,
/// from the camera calibration), F_i and X: its spread about its mean over the views [mm].
Spread CornerSpreadInBase(const std::vector<geometry::Pose3>& camera_from_board,
                          const std::vector<geometry::Pose3>& base_from_flange,
                          const geometry::Pose3& flange_from_camera,
                          const ChessboardSpec& board);

}  // namespace mlp::calib
