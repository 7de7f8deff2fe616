#pragma once
/// @file A tool camera's image folder on disk (`mlprobe-tool-images/1`, docs/TOOLCAM.md): the
/// manifest `images.json` a tool camera records beside its images, with the camera, the strobe,
/// the spindle's shift and, per image, its file and angular position. Read and written here
/// only; the pixels are the caller's (any format OpenCV reads).

#include "mlp/toolcam/tool_camera.h"

#include <string>
#include <vector>

namespace mlp::toolcam {

struct ToolImages {
  ToolCameraModel camera;
  bool calibrated = false;  ///< the manifest holds the camera's calibration (axis and tip)
  SpindleShift shift;
  /// The spindle turned M4 (counterclockwise seen from the spindle) for the images; `position`
  /// is then already counted the measurement's way (M3's: N - p).
  bool m4 = false;
  int positions = 0;               ///< strobe positions per turn
  double blur_rad = 0;             ///< the tool's turn during a pulse
  std::vector<std::string> files;  ///< relative to the manifest's folder
  std::vector<int> position;       ///< each image's strobe position
  /// Each image's angle as measured where the strobe gives it (`angle_deg` from an encoder, or
  /// `time_us` since the spindle's index pulse at the strobe's rpm) [deg], counted the
  /// measurement's way as `position` is; empty when the manifest gives none (the plan's
  /// positions stand). `position` is then the nearest strobe position.
  std::vector<double> angle_deg;
  /// Each image's own pulse (`pulse_width_us` per image: the exposure a strobe reports) as the
  /// tool's turn during it [rad]; empty: `blur_rad` for all.
  std::vector<double> image_blur_rad;
};

/// Reads `images.json` text; throws ToolInputError naming `where` and the field.
ToolImages ParseToolImages(const std::string& text, const std::string& where);

/// The manifest of images rendered or recorded with `camera` under `plan`'s strobe.
std::string ToolImagesJson(const ToolCameraModel& camera,
                           const StrobePlan& plan,
                           const SpindleShift& shift,
                           const std::vector<std::string>& files,
                           const std::vector<int>& position);

}  // namespace mlp::toolcam
