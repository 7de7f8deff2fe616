#pragma once
/// @file Quick re-calibration after a disturbance (seed 002): the probe re-seated, a light crash,
/// the window glass replaced. Instead of a full hand-eye, the sphere is measured at one or a few
/// spindle/head orientations and the change of the mount is solved from the original
/// calibration:
///
///   H_i (M0 dM) q_i = c0 (+ dc)      q_i: the sphere centre measured in the probe frame
///
/// - one orientation: a pure offset dt (the correction vector, the same in every orientation
///   once expressed in the flange frame);
/// - two or more: the offset and the rotation of the mount, as far as the orientations separate
///   them (what they cannot separate is left at the original value and reported);
/// - sphere moved (re-mounted): dc as well; three orientations or more.
/// The update is always relative to the original calibration, never to an earlier update.

#include "mlp/calib/hand_eye.h"

#include <string>
#include <vector>

namespace mlp::calib {

struct RecheckOptions {
  double sphere_radius_mm = 12.7;
  Pose3 original_flange_from_probe = Pose3::Identity();  ///< M0 of the original calibration
  Vec3 original_centre_mcs = Vec3::Zero();               ///< c0
  bool sphere_moved = false;  ///< solve the sphere centre too (needs 3+ orientations)
  /// Largest change a quick re-calibration may make; beyond, a full calibration is required.
  double max_offset_mm = 0.5;
  double max_rotation_deg = 0.2;
  /// Largest centre residual after the correction [mm]; beyond, the disturbance is not a
  /// rigid change of the mount (a bent probe, a loose window) and a full calibration is required.
  double max_residual_mm = 0.005;
  /// Largest change of the probe's depth scale a quick re-calibration accepts (0.3 %: 0.3 mm at
  /// a 100 mm stand-off). A scale is the camera/projector calibration, not the mount: beyond this
  /// and 3 sigma it is reported as such and a full calibration is required.
  double max_depth_scale_change = 0.003;
  double lever_mm = 100.0;  ///< turns rotations into lengths when deciding what is determined
  void Check() const;
};

struct RecheckCapture {
  std::string id;
  Pose3 mcs_from_flange = Pose3::Identity();
  geometry::Points3 points_in_probe;
};

struct RecheckResult {
  Pose3 flange_from_probe = Pose3::Identity();  ///< M0 dM
  Vec3 centre_mcs = Vec3::Zero();               ///< c0 + dc
  Vec3 offset_in_flange_mm = Vec3::Zero();      ///< dt
  Vec3 rotation_in_flange_rad = Vec3::Zero();   ///< dM's rotation vector
  Vec3 centre_shift_mm = Vec3::Zero();          ///< dc
  /// Sphere-centre residual per capture before and after the correction [mm].
  std::vector<double> residual_before_mm, residual_after_mm;
  double residual_after_rms_mm = 0.0;
  /// Mean fitted sphere radius minus the nominal: a changed window or a dirty lens shows here
  /// before it shows in the centres (seed 002's "apparent tip-radius change").
  double apparent_radius_change_mm = 0.0;
  /// The depth scale of the probe's readings (true z = scale x read z) shared by the captures,
  /// with the radius held: a plane cut of a sphere is a circle, so a cap that is too shallow or
  /// too deep for its width says the scale. Applied to the centres only when it is a finding.
  double depth_scale = 1.0, depth_scale_std = 0.0;
  std::vector<std::string> not_determined;  ///< kept at the original value, in words
  bool full_calibration_required = false;
  std::string reason;  ///< why a full calibration is required (empty otherwise)
};

/// Throws HandEyeError (kBadInput) for unusable input and (kUnderDetermined) for exactly two
/// orientations (a shift and a turn of the mount they cannot tell apart) or when the sphere is
/// declared moved and fewer than 3 orientations were measured.
RecheckResult Recheck(const std::vector<RecheckCapture>& captures, const RecheckOptions& options);

/// Seed 002's "a calibration artefact or other feature": a surface of the part in the machine,
/// measured with the original calibration before the disturbance (a bore's axis and radius, or
/// a face), is the artefact. Measured again after it, the mount's change is what puts the new
/// points back on it. A point says only its distance from the surface: a face leaves the offsets
/// along itself open, a bore seen from one side the offset along its axis and more; a direction
/// the views determine worse than 0.5 um (1 sigma, from the points' own scatter) is kept from the
/// original and listed, as with the sphere. The surface must not have moved.
struct PartSurface {
  enum class Kind { kCylinder, kPlane };
  Kind kind = Kind::kCylinder;
  Vec3 point_mcs = Vec3::Zero();       ///< on the axis, or on the plane
  Vec3 direction_mcs = Vec3::UnitZ();  ///< the axis, or the plane's normal
  double radius_mm = 0.0;              ///< a cylinder's
  /// Signed distance of a point from the surface [mm]: + outside a cylinder's radius, + on the
  /// normal's side of a plane.
  double Distance(const Vec3& x_mcs) const;
};

/// The mount and limits of `options` (its sphere fields are not used); `max_residual_mm` bounds
/// the RMS over the captures of their points' mean distance from the surface after the
/// correction. In the result, per capture residuals are that mean distance (absolute), the
/// centre fields are the original's, and the apparent radius change is the mean over the
/// captures of their mean distance before the correction (a bore read larger, +: views all round
/// it cancel a sideways move but not a changed depth reading, which to walls seen from inside
/// is the same as a mount offset along the view). Throws HandEyeError (kBadInput).
RecheckResult RecheckOnPart(const std::vector<RecheckCapture>& captures,
                            const PartSurface& surface,
                            const RecheckOptions& options);

}  // namespace mlp::calib
