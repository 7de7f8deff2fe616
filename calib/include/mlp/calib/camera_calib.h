#pragma once
/// @file Camera intrinsics and distortion from images of a planar chessboard (Zhang, "A
/// flexible new technique for camera calibration", PAMI 2000, as OpenCV implements it: corners
/// found and refined to sub-pixel, then calibrateCamera with Brown-Conrady k1 k2 p1 p2 k3).
/// OpenCV stays behind this header.

#include "mlp/base/input_error.h"
#include "mlp/geometry/types.h"

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::calib {

struct GrayImage {
  int width = 0, height = 0;
  int bit_depth = 8;
  std::vector<std::uint16_t> pixels;  ///< row-major
};

struct ChessboardSpec {
  int inner_cols = 0, inner_rows = 0;  ///< inner corners along the board's x and y
  double square_mm = 0.0;
};

struct Intrinsics {
  double fx_px = 0, fy_px = 0, cx_px = 0, cy_px = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  /// Distorted pixel of a point in the camera frame (OpenCV's model).
  geometry::Vec2 Project(const geometry::Vec3& point_in_camera) const;
};

struct CameraCalibration {
  Intrinsics intrinsics;
  /// 1-sigma of fx fy cx cy k1 k2 p1 p2 k3 from the fit's covariance (OpenCV).
  Intrinsics std_dev;
  double rms_reprojection_px = 0.0;
  std::vector<double> view_rms_px;                 ///< per image used
  std::vector<int> views_used;                     ///< indices into the input images
  std::vector<geometry::Pose3> camera_from_board;  ///< per image used
  std::vector<std::string> warnings;               ///< images without a board, and why
};

class CameraCalibError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// Needs the board found in at least 4 images; throws CameraCalibError otherwise.
CameraCalibration CalibrateCamera(const std::vector<GrayImage>& images,
                                  const ChessboardSpec& board);
/// Each image's board pose with a camera known already (OpenCV's solvePnP, iterative), and its
/// corners' reprojection RMS: `intrinsics` as given, `std_dev` zero, `rms_reprojection_px` over
/// all views. Throws CameraCalibError when no image has the board.
CameraCalibration BoardPosesWithCamera(const std::vector<std::vector<geometry::Vec2>>& found,
                                       const ChessboardSpec& board,
                                       const Intrinsics& camera);
/// The same from corners found beforehand (per image, board order; empty: no board).
CameraCalibration CalibrateCameraFromCorners(
    const std::vector<std::vector<geometry::Vec2>>& corners,
    const ChessboardSpec& board,
    int width_px,
    int height_px);

}  // namespace mlp::calib
