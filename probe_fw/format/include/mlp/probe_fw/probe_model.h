#pragma once
/// @file The probe model: everything that turns pixels into millimetres, and what the virtual
/// probe needs to render frames a real probe would take. One JSON file format (docs/PROBE_MODEL.md)
/// read by the firmware and the virtual probe, written by calibration.
///
/// Frames: the probe frame P is the camera's optical frame (x right, y down, z forward) [mm].
/// The projector is an inverse 1-D camera: projector column u (continuous) is the light plane
/// x_proj / z_proj = (u - c) / f in the projector frame, whose pose is camera_from_projector.

#include "mlp/base/input_error.h"
#include "mlp/geometry/types.h"

#include <stdexcept>
#include <string>

namespace mlp::probe_fw {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

/// Pinhole camera with Brown-Conrady distortion, OpenCV's convention (k1 k2 p1 p2 k3).
struct CameraModel {
  int width_px = 0;
  int height_px = 0;
  int bit_depth = 8;            ///< bits per pixel, 8..16
  double pixel_pitch_mm = 0.0;  ///< sensor pixel size
  double fx_px = 0.0, fy_px = 0.0, cx_px = 0.0, cy_px = 0.0;
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  /// The lens's aperture and focus, optional (0: not given). The firmware needs neither to
  /// triangulate; the virtual probe renders speckle grain and defocus from them (docs/PROBE.md).
  double f_number = 0.0;           ///< f / D, f = fx_px * pixel_pitch_mm, D the entrance pupil
  double focus_distance_mm = 0.0;  ///< depth (z) of sharp focus

  /// Distorted pixel of a point in the camera frame (z > 0).
  Vec2 Project(const Vec3& point_in_probe) const;
  /// Normalised undistorted image coordinates (x/z, y/z) of a distorted pixel; Newton iteration
  /// to 1e-12 (OpenCV's undistortPoints stops after 5 fixed-point steps: ~1e-4 px at the corner).
  Vec2 Undistort(const Vec2& pixel) const;
  /// Largest pixel value (2^bit_depth - 1).
  int MaxLevel() const { return (1 << bit_depth) - 1; }
  /// Half-angle sin u of the observation aperture seen from a point at depth z [mm] (Dorsch et
  /// al. 1994's u_obs): entrance pupil radius over distance; 0 when the f-number is not given.
  double ApertureSinAt(double depth_mm) const;
};

/// The MEMS line projector as an inverse camera with one coordinate: the mirror angle theta maps to
/// column u = c_px + f_px tan(theta).
///
/// A real mirror and line generator (issue 16) add two terms, both 0 in a design: the mirror's
/// angle is not linear in the commanded column (the sheet of commanded column u is that of
/// actual column u + mirror_cubic_cols s^3, s = (u - c_px) / (columns / 2)), and the sheet is
/// curved (the sheet of actual column u reaches the points whose planar column ColumnOf is
/// u + sheet_smile_cols (t / tan(fan_half_angle_deg))^2, t = y / z in the projector frame:
/// a line generator's "smile"). Calibration estimates both.
struct ProjectorModel {
  double f_px = 0.0;
  double c_px = 0.0;
  int columns = 0;  ///< addressable mirror positions: u in [0, columns)
  Pose3 camera_from_projector = Pose3::Identity();
  double mirror_cubic_cols = 0.0;  ///< at the ends of the range [columns]
  double sheet_smile_cols = 0.0;   ///< at the fan's edge [columns]
  double fan_half_angle_deg = 25.0;

  /// Continuous planar column of a point given in the camera (probe) frame: where a flat sheet
  /// of a linear mirror would put it.
  double ColumnOf(const Vec3& point_in_probe) const;
  /// Light plane of actual column u in the camera frame: unit normal n and offset d, n.x = d.
  void PlaneOf(double column, Vec3* normal_in_probe, double* offset_mm) const;
  /// The mirror's actual column of a commanded one, and its inverse (Newton, to 1e-12).
  double ActualColumn(double commanded) const;
  double CommandedColumn(double actual) const;
  /// The actual column whose (curved) sheet reaches a point.
  double SheetColumnOf(const Vec3& point_in_probe) const;
  /// The commanded column that lights a point: the smile and the mirror undone.
  double CommandedColumnOf(const Vec3& point_in_probe) const {
    return CommandedColumn(SheetColumnOf(point_in_probe));
  }
  /// The smile's column offset at along-line position t = y / z (projector frame).
  double SmileAt(double t) const;
  /// Whether the model has the terms of a real mirror and sheet (a /2 file).
  bool Curved() const { return mirror_cubic_cols != 0.0 || sheet_smile_cols != 0.0; }
  /// Projector centre in the camera frame.
  Vec3 Center() const { return camera_from_projector.translation(); }
};

/// The laser sheet: Gaussian across the sheet, 1/e^2 half-width in projector columns.
struct LaserModel {
  double wavelength_nm = 0.0;
  double sheet_halfwidth_cols = 0.0;
};

/// Photometry and noise of the camera, in electrons (e-).
struct NoiseModel {
  double full_well_e = 0.0;
  double read_noise_e = 0.0;      ///< Gaussian, per pixel and frame
  double laser_peak_e = 0.0;      ///< stripe peak on a white Lambertian face at normal incidence
  double led_e = 0.0;             ///< LED ring on a white face facing the camera
  double ambient_e = 0.0;         ///< shop light on a white face
  double speckle_contrast = 0.0;  ///< std/mean of the multiplicative speckle on laser light
  double stripe_centre_noise_px =
      0.0;  ///< expected 1-sigma stripe-centre noise (spec, informative)
};

/// How well the camera/projector calibration fitted its data (present in calibrated files; the
/// firmware does not need it, a person checking the probe does).
struct CalibrationStats {
  bool present = false;
  int views = 0, corners = 0, stripe_points = 0;
  double corner_rms_px = 0.0;       ///< chessboard corners, reprojection
  double stripe_rms_columns = 0.0;  ///< stripe points vs their light planes, projector columns
};

struct ProbeModel {
  std::string serial;
  std::string calibration_id;
  CalibrationStats calibration_stats;
  CameraModel camera;
  ProjectorModel projector;
  LaserModel laser;
  NoiseModel noise;

  /// Throws ProbeModelError naming the first field out of range.
  void Validate() const;
};

class ProbeModelError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// Parses and validates; throws ProbeModelError with the field name on any problem.
ProbeModel ParseProbeModel(const std::string& json_text);
ProbeModel LoadProbeModel(const std::string& path);
/// JSON text that ParseProbeModel reads back to the same model (round trip to 17 digits).
std::string ToJson(const ProbeModel& model);
/// Writes atomically (temporary file + rename).
void SaveProbeModel(const ProbeModel& model, const std::string& path);

}  // namespace mlp::probe_fw
