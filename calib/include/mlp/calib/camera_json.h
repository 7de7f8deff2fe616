#pragma once
/// @file The probe camera's calibration as JSON: the intrinsics' fields (shared by every report
/// that carries a camera) and the camera calibration file `mlprobe-camera/1`, written by
/// `mlp calibrate camera --out` and read back here, in one place (docs/CALIBRATION.md).

#include "mlp/calib/board_views.h"
#include "mlp/calib/camera_calib.h"

#include <string>

#include <nlohmann/json.hpp>

namespace mlp::calib {

inline constexpr const char* kCameraFileFormat = "mlprobe-camera/1";

/// fx_px fy_px cx_px cy_px k1 k2 p1 p2 k3 (OpenCV's model).
nlohmann::ordered_json IntrinsicsJson(const Intrinsics& k);

/// Per view: its capture id and folder, and its RMS or why it was skipped.
nlohmann::ordered_json BoardViewsJson(const BoardViews& views, const CameraCalibration& c);

/// The `mlprobe-camera/1` document: the probe, the board, the image size, the intrinsics and
/// their 1-sigma, the reprojection RMS and the views.
nlohmann::ordered_json CameraFileJson(const BoardViews& views, const CameraCalibration& c);

/// What a `mlprobe-camera/1` file gives back.
struct CameraFile {
  std::string probe_serial;
  int width_px = 0, height_px = 0;
  Intrinsics intrinsics, std_dev;
  double rms_reprojection_px = 0.0;
};

/// Reads a `mlprobe-camera/1` document; throws CameraCalibError naming `source` and the field
/// (not JSON, another format, a missing or non-finite number, focal lengths not positive).
CameraFile ParseCameraFile(const std::string& text, const std::string& source);

}  // namespace mlp::calib
