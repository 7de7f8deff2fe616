#pragma once
/// @file The virtual tool camera: back-lit shadow frames of a tool turning in the spindle, frozen
/// by strobe pulses (seed 000), with the blur of the pulse's length, the optics' blur and
/// distortion, sensor noise, and coolant drops and chips in random places. Deterministic for a
/// seed; the truth (each edge's radius and tip, each frame's angle, each drop) is known.
///
/// Camera: telecentric (orthographic), looking along the tool frame's +x, so a pixel sees a
/// point (y, h) of the tool frame: y = (u - axis_u_px) mm_per_px, h = (tip_v_px - v) mm_per_px
/// for pixel centres (u, v) before distortion, when the camera is square to the spindle. With
/// the axis outside the image (a tool wider than the field), the frame shows one side of the
/// tool near its tip.
///
/// Mounted less than square (seed 000 example 4: the optical axis' tilt about x and y): `roll`
/// turns the tool's image about (axis_u_px, tip_v_px), the spindle axis leaning right going
/// down for roll > 0; `pitch` tilts the view along the axis, a ray through image height h
/// meeting depth x (away from the camera) at height h + x tan(pitch), so what is farther looks
/// lower for pitch > 0. The measurement maps pixels with the roll and sees the edges' ends
/// with the pitch (both from the camera's calibration, pin_calibration.h).

#include "mlp/geometry/types.h"
#include "mlp/toolcam/strobe.h"
#include "mlp/toolcam/tool_model.h"

#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

namespace mlp::toolcam {

struct ToolCameraModel {
  int width_px = 1024, height_px = 768;
  double mm_per_px = 0.004;   ///< object side
  double axis_u_px = -738.0;  ///< column of the spindle axis (y = 0)
  double tip_v_px = 560.0;    ///< row of the nominal tip (h = 0)
  /// Radial distortion: a point at the image's corner moves by this share of its distance
  /// from the centre (telecentric lenses: under 0.1 %).
  double distortion_k1 = 0.0005;
  /// Tangential (decentring) distortion, Brown's p1 and p2 in the same corner units (Brown,
  /// "Decentering distortion of lenses", 1966): a lens whose elements are not quite centred.
  double distortion_p1 = 0.0, distortion_p2 = 0.0;
  /// The centre of the distortion (the lens' principal point) [px]; unset: the image's centre.
  std::optional<double> principal_u_px, principal_v_px;
  double psf_sigma_px = 0.7;               ///< the optics' blur
  double bright = 210, dark = 25;          ///< grey levels of the back-light and the shadow
  double noise_sigma = 2.0;                ///< grey levels, Gaussian
  double drops_per_frame = 1.5;            ///< coolant drops and chips (mean, Poisson)
  double roll_deg = 0.0, pitch_deg = 0.0;  ///< up to 5 deg each
  /// Rendering only: the glass block of seed 000 Fig. 7 brought into view, its ground-glass
  /// face this high in the tool frame [mm] (dark below it: the plate scatters the back-light);
  /// absent: no block.
  std::optional<double> glass_face_h_mm;
  /// Rendering only: the block's side face, standing along the spindle axis this far across in
  /// the tool frame [mm] (dark beyond it, away from the axis): a stylus moved sideways against
  /// it; absent: none.
  std::optional<double> glass_side_y_mm;
  /// Where the distortion is centred [px]: the principal point, or the image's centre.
  geometry::Vec2 LensCentre() const;
  /// A pixel's ideal position, the lens' distortion undone: about the lens' centre, at rho
  /// corner units from it, (d - t(d)) / (1 + k1 rho^2) with t Brown's tangential shift. The
  /// tangential terms taken at the distorted point: exact to first order in p (their square,
  /// 1e-8 of the distance, is far under a micrometre).
  geometry::Vec2 Undistort(const geometry::Vec2& px) const;
  /// Its inverse (for drawing on the image).
  geometry::Vec2 Distort(const geometry::Vec2& ideal_px) const;
  /// The image's half-diagonal squared [px^2]: the unit the distortion's terms are given in.
  double Corner2() const;
  /// Tool frame (y, h) [mm] of an ideal (undistorted) pixel position, and back.
  geometry::Vec2 ToolFromPixel(const geometry::Vec2& px) const;
  geometry::Vec2 PixelFromTool(const geometry::Vec2& yh) const;
  void Validate() const;  ///< throws ToolInputError naming the field
};

/// A coolant drop or chip in a frame: a disc in the (y, h) plane.
struct Drop {
  double y_mm = 0, h_mm = 0, radius_mm = 0;
};

struct ToolFrame {
  std::vector<std::uint8_t> pixels;  ///< row-major, width x height
  std::vector<Drop> drops;
};

/// One frame with the tool turned `turn_rad` (the pulse's middle) and turning `blur_rad` while
/// the pulse lasts.
ToolFrame RenderToolFrame(const ToolDescription& tool,
                          const ToolCameraModel& camera,
                          double turn_rad,
                          double blur_rad,
                          std::mt19937& rng);

/// Where the NC put the spindle for the images, from where it stood when the camera was
/// calibrated (as the camera sees the machine's axes: y across the image, z up the spindle):
/// what a camera's manifest records beside its images (pin_calibration.h, CameraFor).
struct SpindleShift {
  double y_mm = 0.0, z_mm = 0.0;
};

/// The frames of a strobe plan, written as DIR/frame_NNNN.pgm, DIR/images.json (format
/// `mlprobe-tool-images/1`: what a real camera records: each image's position, the strobe,
/// the image size and lens, the spindle's shift, and the camera's calibration as the virtual
/// camera knows it) and DIR/truth.json (`mlprobe-tool-frames/1`: the camera, the tool's truth
/// per edge, each frame's angle and drops). The tool's angle at the first image is
/// `start_turn_rad` (unknown to the measurement). `drift_across_mm` puts the spindle axis that
/// far across the image from where the camera's calibration has it (a spindle grown warm, seed
/// 000 example 7): drawn there, the manifest recording the calibration, the truth both.
/// Returns the number of frames.
int RenderToolSequence(const ToolDescription& tool,
                       const ToolCameraModel& camera,
                       const StrobePlan& plan,
                       double start_turn_rad,
                       unsigned seed,
                       const std::string& dir,
                       const SpindleShift& shift = {},
                       double drift_across_mm = 0.0);

/// Writes an 8-bit binary PGM (P5) atomically; throws ToolError.
void WritePgm(const std::string& path, int width, int height, const std::vector<std::uint8_t>& px);

}  // namespace mlp::toolcam
