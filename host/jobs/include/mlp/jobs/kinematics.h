#pragma once
/// @file The trunnion check job (docs/HOSTD.md `{"op": "kinematics"}`, issue 54), typed: a
/// reference sphere on the C table captured at a plan of A and C positions, each capture's
/// points in the machine frame (H from the joints, not through the kinematics) -> each
/// capture's sphere centre, the rotary axes' lines against the controller's pins, the verdict.

#include "mlp/calib/trunnion.h"
#include "mlp/calib/trunnion_report.h"
#include "mlp/geometry/types.h"

#include <optional>
#include <string>
#include <vector>

namespace mlp::jobs {

struct KinematicsCapture {
  std::string id;
  double a_deg = 0.0, c_deg = 0.0;   ///< the rotary joints at rest, as the controller read them
  geometry::Points3 points_machine;  ///< H M p, H from the joints alone
};

struct KinematicsInputs {
  std::vector<KinematicsCapture> captures;
  double sphere_radius_mm = 0.0;  ///< the reference sphere's calibrated radius
  calib::TrtPins pins;            ///< the controller's, as read with the captures
  calib::TrunnionLimits limits;
  /// A capture whose free sphere fit is this far from the calibrated radius is not of the
  /// reference sphere (or not all of it): refused rather than given a centre.
  double max_radius_error_mm = 0.05;
  /// Fewer points on the sphere than this and the capture gives no centre.
  int min_points = 200;
  /// A calibration: the pins that put the kinematics on the fitted lines (calib::PinsFor),
  /// each changed only where its change exceeds both the null band and 3 of its uncertainties
  /// (right pins change nothing), and refused whole when a change exceeds max_change_mm (a
  /// crash or a wrong sphere, not a calibration).
  bool calibrate = false;
  double null_band_mm = 0.002;
  double max_change_mm = 0.2;
};

using PinChange = calib::PinChange;

/// One capture's sphere, radius held at the calibrated value.
struct SphereSeen {
  std::string id;
  double a_deg = 0.0, c_deg = 0.0;
  geometry::Vec3 centre_machine_mm = geometry::Vec3::Zero();
  double free_radius_mm = 0.0;   ///< the radius a free fit of the same points gives
  double rms_mm = 0.0;           ///< radius held, over the points used
  int points = 0, left_out = 0;  ///< used, and left out as off the sphere (robust trimming)
};

struct KinematicsOutcome {
  std::vector<SphereSeen> spheres;
  std::vector<std::string> problems;  ///< why nothing is determined; empty when fitted
  std::optional<calib::TrunnionFit> fit;
  bool within = false;  ///< every pivot and squareness within its limit
  /// With `calibrate`: every pin looked at, and the pins to write (the current ones where
  /// none changed).
  std::vector<PinChange> changes;
  std::optional<calib::TrtPins> new_pins;
};

/// The check. Problems (a capture without its sphere, a radius far from the calibrated one,
/// positions that cannot determine the axes, centres no two lines explain) leave `fit` empty.
KinematicsOutcome AssessKinematics(const KinematicsInputs& inputs);

/// The sphere centre of points in the machine frame, radius held: a robust free fit picks the
/// points on the sphere and starts Gauss-Newton on them. Throws geometry::GeometryError.
SphereSeen SphereOf(const geometry::Points3& points_machine, double radius_mm);

}  // namespace mlp::jobs
