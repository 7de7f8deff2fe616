#pragma once
/// @file The tool camera against the machine from a calibration pin (seed 000 example 4): a
/// ground cylinder of known diameter and length (gauge point to its flat end) turning slowly
/// in the spindle, both flanks and the end in view, and below the end two blades (round rods
/// parallel to the axis, far apart in depth, of pre-calibrated lengths).
///
/// - The flanks give the scale (their distance is the diameter) and the spindle axis: their
///   middle line's column (the optical axis' y offset) and its turn in the image (the tilt about
///   x, `roll`).
/// - The blades give the tilt about y (`pitch`): the view meets depth x at height
///   h + x tan(pitch), so a blade's end looks higher or lower by its depth times tan(pitch).
///   Each blade's depth in each image is the rate its y changes with the turn (y = o sin a,
///   x = o cos a = dy/da), from a sine fitted to its y over the turn; the ends' heights against
///   the depths, least squares over every image where the blades stand apart, give tan(pitch)
///   and the end's height free of it (the optical axis' z offset). The seed compares the two
///   principal images 180 deg apart; the fit over all images is the same idea with more data.
/// - The lens' radial distortion (seed 000 example 3 measures "on an accurate distortion
///   calibration"): a ground flank is straight, the lens bends it by k1 rho^2 (p - centre); its
///   rows over the field's height, both flanks, every image, give k1 by linear least squares
///   before anything else is measured (the manifest's value is the lens' nominal only).
/// - Without blades, the end's row gives the height and the pitch is not measured (a pitched
///   view lowers a flat end by up to its radius times tan(pitch): 2.6 um for 0.1 deg on D3).
///
/// Positions count the tool's turn about +z of the tool frame (z up into the spindle); counted
/// the other way, the pitch comes out with the wrong sign.

#include "mlp/toolcam/frame_loop.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"

#include <cstdint>
#include <string>
#include <vector>

namespace mlp::toolcam {

struct PinCalibration {
  double mm_per_px = 0.0;
  double roll_deg = 0.0;        ///< tilt about x: the spindle axis leaning right going down
  double pitch_deg = 0.0;       ///< tilt about y; 0 when not measured
  bool pitch_measured = false;  ///< the pin has blades and enough images showed them apart
  double end_u_px = 0.0, end_v_px = 0.0;      ///< the pin's end on the spindle axis (h = 0)
  double gauge_u_px = 0.0, gauge_v_px = 0.0;  ///< the gauge point, the pin's length up the axis
  /// The lens' radial distortion (ToolCameraModel::distortion_k1) from the flanks'
  /// straightness, and whether it was measured (the flanks must span enough of the field).
  double distortion_k1 = 0.0;
  bool distortion_measured = false;
  double distortion_sigma = 0.0;  ///< k1's standard error from the flanks (NaN: not fitted)
  double width_rms_px = 0.0;      ///< of the flanks' distance over the rows: the pin's roundness
  double blade_rms_um = 0.0;      ///< of the blades' end heights about the fit
  int rows = 0;                   ///< flank rows used
  int blade_images = 0;           ///< images where both blades were measured

  /// The camera for a tool of `length_mm` (gauge point to its nominal tip) with the spindle
  /// moved by (`shift_y_mm`, `shift_z_mm`) from where it stood for the calibration (as the
  /// camera sees the machine's axes: y across the image, z up the spindle): `base` (size,
  /// lens, light) with this calibration, its tip row and axis column where the tool's nominal
  /// tip is.
  ToolCameraModel CameraFor(const ToolCameraModel& base,
                            double length_mm,
                            double shift_y_mm = 0.0,
                            double shift_z_mm = 0.0) const;
  /// The frame loop (frame_loop.h) this calibration closes: the detector's mount from the
  /// gauge point's pixel and the roll, the machine's structure, support and carriage square
  /// to the spindle at the calibration's place, the encoders at the spindle's shift, the tool
  /// `length_mm` long. CameraFor is the camera through it.
  FrameLoop Loop(double length_mm, double shift_y_mm = 0.0, double shift_z_mm = 0.0) const;
};

/// The calibration as a file (`mlprobe-tool-camera/1`, docs/TOOLCAM.md): the figures above,
/// the image size and lens it holds for, and the pin it came from.
std::string CameraCalibrationJson(const PinCalibration& p,
                                  const ToolCameraModel& base,
                                  const std::string& pin_id);
/// Parses it; `base` gets the image size and the lens. Throws ToolInputError naming `where`
/// (the file) and the field.
PinCalibration ParseCameraCalibration(const std::string& json_text,
                                      ToolCameraModel* base,
                                      const std::string& where = "camera calibration");

/// `frames[i]` shows the pin turned to position `positions[i]` of `position_count` (the blades'
/// depths need at least 8 images spread round the turn; a pin without blades needs one).
/// `camera` gives the image size (its distortion is measured, `camera`'s only a fallback when
/// the flanks span under a quarter of the image's height). Throws ToolError when the images do
/// not show both flanks and the end, or the blades are not seen apart in enough images.
PinCalibration CalibrateWithPin(const std::vector<std::vector<std::uint8_t>>& frames,
                                const std::vector<int>& positions,
                                int position_count,
                                const ToolCameraModel& camera,
                                const ToolDescription& pin);

}  // namespace mlp::toolcam
