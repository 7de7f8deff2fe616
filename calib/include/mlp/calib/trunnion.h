#pragma once
/// @file A trunnion's rotary axes (issue 54): a tilting table A carrying a rotary table C, as
/// LinuxCNC's `xyzac-trt-kins` models it, and its axes' centre lines found from a sphere on the
/// C table measured at a plan of A and C positions (the check Renishaw's AxiSet, Heidenhain's
/// KinematicsOpt and Siemens' CYCLE996 make with a touch probe).
///
/// Frames: the machine frame (the joints X, Y, Z) and the table frame, which is the machine frame
/// carried by the table: both coincide at A = C = 0. A point s fixed to the C table is, at joint
/// angles (a, c), in the machine frame at
///
///   m(a, c) = Rot(A axis, a) Rot(C axis at A = 0, c) s
///
/// where Rot(L, t) turns about the line L (point o, unit direction u) by t, right-handed about u:
/// x -> o + R(u, t) (x - o). C turns first (it rides on the cradle), then A turns both.
///
/// LinuxCNC's kinematics holds the A axis parallel to X through (y-rot-point + y-offset,
/// z-rot-point + z-offset + tool-offset) and the C axis parallel to Z through (x-rot-point,
/// y-rot-point); only those four sums are observable and only they enter the kinematics. What a
/// real trunnion adds (A not parallel to X, C not square to the table, an A zero that is off) the
/// fit below estimates and reports even where those pins cannot hold it.

#include "mlp/geometry/types.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::calib {

using geometry::Pose3;
using geometry::Vec3;

/// The HAL pins of `xyzac-trt-kins` [mm], by their names.
struct TrtPins {
  double x_rot_point = 0.0, y_rot_point = 0.0, z_rot_point = 0.0;
  double y_offset = 0.0, z_offset = 0.0, tool_offset = 0.0;
};

/// A line in the machine frame at A = C = 0.
struct AxisLine {
  Vec3 point = Vec3::Zero();
  Vec3 direction = Vec3::UnitZ();  ///< unit
};

/// The two rotary axes' centre lines at A = C = 0 in the machine frame.
struct TrunnionAxes {
  AxisLine a{Vec3::Zero(), Vec3::UnitX()};
  AxisLine c{Vec3::Zero(), Vec3::UnitZ()};
};

/// The axes as `xyzac-trt-kins` has them: A along X, C along Z, through the pins' points.
TrunnionAxes AxesOf(const TrtPins& pins);

/// The rigid motion of the table at joint angles (a, c) [deg]: machine <- table.
Pose3 MachineFromTable(const TrunnionAxes& axes, double a_deg, double c_deg);

/// The spindle flange's pose in the table's frame (H, where the part and the sphere live) from
/// the joints: the gauge point at (x, y, z) in the machine frame, the spindle turned by
/// `spindle_deg` about machine Z (M19), the table at (a, c) [deg]; the flange frame as the
/// three-axis machine's, H = MachineFromTable(a, c)^-1 T(x, y, z) Rz(spindle) Rx(180 deg)
/// (z along the tool out of the spindle).
Pose3 TableFromFlange(const TrunnionAxes& axes,
                      const Vec3& gauge_point_machine_mm,
                      double a_deg,
                      double c_deg,
                      double spindle_deg);

/// A plan of sphere captures on the trunnion: the probe looking straight down (the spindle
/// untilted, oriented to `spindle_deg`), its origin `standoff_mm` above the sphere's centre,
/// the gauge point `probe_length_mm` above that.
struct TrunnionPlanOptions {
  std::vector<double> a_deg{-30.0, 0.0, 30.0, 60.0, 90.0};
  int c_count = 4;  ///< C positions per A, evenly over a turn from 0
  double spindle_deg = 0.0;
  double probe_length_mm = 140.0, standoff_mm = 125.0;
  /// The table as a disc of this radius on the plane z = table_top_mm of the table's frame
  /// (0: not modelled): the clearance height keeps the probe's tip above its rim at every tilt.
  double table_radius_mm = 0.0, table_top_mm = 0.0;
  double margin_mm = 20.0;  ///< above the highest thing met while turning
  void Check() const;
};

struct TrunnionStop {
  double a_deg = 0.0, c_deg = 0.0;
  Vec3 gauge_machine_mm = Vec3::Zero();  ///< where the spindle's gauge point stops (joints)
};

/// The stops in order (C fastest) and the gauge point's height every turn is made at: above
/// every stop's probe tip and the table's rim at every tilt of the plan, plus the margin.
/// The approach to each stop: retract to the clearance height, turn A and C there, move over
/// the stop, go down to it.
struct TrunnionPlan {
  std::vector<TrunnionStop> stops;
  double clear_gauge_z_mm = 0.0;
};

/// The plan for a sphere at `sphere_table_mm` (table frame) on a trunnion moving about `axes`.
/// Throws TrunnionError for options that cannot make a determining plan (under 3 A positions
/// or 3 C positions) or a non-finite input.
TrunnionPlan PlanTrunnionCheck(const TrunnionAxes& axes,
                               const Vec3& sphere_table_mm,
                               const TrunnionPlanOptions& options = {});

/// One sphere centre measured in the machine frame with the table at (a, c) [deg].
struct TrunnionObservation {
  double a_deg = 0.0, c_deg = 0.0;
  Vec3 centre_machine_mm = Vec3::Zero();
};

struct TrunnionFitOptions {
  /// Standard uncertainty of one measured centre per coordinate [mm], used for the covariance
  /// when the residuals are fewer than the parameters allow to estimate it (under 2 degrees of
  /// freedom per parameter); otherwise the residuals' own scatter is used, never less than this.
  double centre_sigma_mm = 0.001;
  /// Where the fit's residual RMS over the centres refuses the result [mm]: the centres are not
  /// one point turned about two lines (a loose sphere, a wrong pose, a crash mid-plan).
  double max_residual_rms_mm = 0.010;
  void Check() const;
};

/// What the fit found, with standard uncertainties (k = 1).
struct TrunnionFit {
  TrunnionAxes axes;
  Vec3 sphere_table_mm = Vec3::Zero();  ///< the sphere centre on the table at A = C = 0
  /// The four sums `xyzac-trt-kins` uses [mm]: C's (x, y) at the A axis' height, A's (y, z) there.
  double c_x_mm = 0, c_y_mm = 0, a_y_mm = 0, a_z_mm = 0;
  double c_x_u_mm = 0, c_y_u_mm = 0, a_y_u_mm = 0, a_z_u_mm = 0;
  /// The axes' squareness, which the controller's kinematics cannot hold [deg]: A's direction
  /// turned from X about Z and about Y; C's direction turned from Z about X (the same as an A
  /// zero that is off) and about Y; the angle between A and C less 90.
  double a_about_z_deg = 0, a_about_y_deg = 0, c_about_x_deg = 0, c_about_y_deg = 0;
  double a_about_z_u_deg = 0, a_about_y_u_deg = 0, c_about_x_u_deg = 0, c_about_y_u_deg = 0;
  double a_c_square_deg = 0, a_c_square_u_deg = 0;
  /// The shortest distance between the two lines [mm] (LinuxCNC's y-offset is its Y part).
  double axes_apart_mm = 0;
  std::vector<double> residual_mm;  ///< per observation: |measured - model|
  double residual_rms_mm = 0;
  int iterations = 0;
};

/// Why a trunnion fit cannot be made: too few or badly spread positions (the plan cannot
/// determine both lines), or centres no pair of lines explains.
class TrunnionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The axes' lines from the sphere centres, starting from `nominal` (the controller's current
/// pins). Needs at least three C positions at one A and three A positions (so each line is a
/// circle's axis), the sphere off the C axis. Throws TrunnionError otherwise, or when the
/// residual RMS exceeds the options' limit.
TrunnionFit FitTrunnion(const std::vector<TrunnionObservation>& observations,
                        const TrunnionAxes& nominal,
                        const TrunnionFitOptions& options = {});

/// The pins that put `xyzac-trt-kins` on the fitted lines, changing the fewest: x/y-rot-point
/// from C, y-offset from A's y less y-rot-point, z-offset from A's z less z-rot-point and the
/// tool offset (z-rot-point and the tool offset kept: only their sum with z-offset matters).
TrtPins PinsFor(const TrunnionFit& fit, const TrtPins& current);

/// One pin a calibration looked at.
struct PinChange {
  std::string name;  ///< as HAL names it: x-rot-point, y-rot-point, y-offset, z-offset
  double before_mm = 0.0, after_mm = 0.0, u_mm = 0.0;
  bool changed = false;  ///< beyond the null band and 3 u
};

/// A calibration's decision (the service's kinematics job and `mlp kinematics calibrate`).
struct PinCalibration {
  std::vector<PinChange> changes;     ///< the four pins PinsFor sets, each looked at
  std::vector<std::string> problems;  ///< why nothing may be written; empty when it may
  TrtPins pins;                       ///< to write: the current ones where a pin did not change
};

/// The pins that put the kinematics on the fitted lines (PinsFor), each changed only where its
/// change exceeds both `null_band_mm` and 3 of its uncertainties (right pins change nothing:
/// a fit's scatter is not written into a machine), and refused whole (`problems`) where a
/// change exceeds `max_change_mm` (a crash, a loose sphere or a wrong plan, not a calibration).
PinCalibration CalibratePins(const TrunnionFit& fit,
                             const TrtPins& current,
                             double null_band_mm,
                             double max_change_mm);

/// A one-paragraph report: each sum against the pins, the squareness, the residuals.
std::string Describe(const TrunnionFit& fit, const TrtPins& current);

}  // namespace mlp::calib
