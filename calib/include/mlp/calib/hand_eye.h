#pragma once
/// @file Sphere hand-eye calibration (seed 004 step 1): the probe's mounting M = flange_from_probe
/// and the reference sphere's centre c (MCS) from clouds of the sphere taken at known flange
/// poses H_i. Each point p (probe frame) must lie on the sphere:
///
///   r(p) = | H_i M p - c | - R          (orthogonal distance, R the known radius)
///
/// minimised over all points with Ceres (Huber loss, then trimming at 3 sigma), started from a
/// closed form: per-capture sphere centres q_i satisfy H_i M q_i = c, linear in (R_M, t_M, c).
///
/// Observability: some pose sets cannot separate parts of M from c (translations only: t_M and c
/// trade off along every axis; spindle orientations about Z only: along Z). The information
/// matrix at the solution shows which combinations the data determine; a combination it does not
/// determine, and that no known centre coordinate pins, is refused with a message that names it
/// and the captures that would fix it.

#include "mlp/geometry/types.h"

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mlp::calib {

using geometry::Pose3;
using geometry::Vec3;

struct SphereCapture {
  std::string id;
  Pose3 mcs_from_flange = Pose3::Identity();  ///< H, from the controller, at standstill
  geometry::Points3 points_in_probe;          ///< may hold background and spurious points
  /// The points are one laser profile (they lie in one plane): the sphere is seen as a circle
  /// and its centre lies on one side of that plane or the other; the closed form tries both.
  bool single_profile = false;
};

/// The sensor's own distortion, estimated with M and c on request (issue 25). A triangulation
/// sensor whose calibration is off reports S p + b (1 - cos a) e_z for a point at p: S a scale per
/// probe axis (the depth scale z, the lateral scales x and y: a projector baseline, a focal length
/// off), b a depth bias that grows with the angle a between the probe's z axis (its direction of
/// view) and the surface normal (laser triangulation on shiny metal reads deeper or shallower as
/// the light grazes). A scale grows with the distance from the probe origin, the bias with the
/// angle: the poses tell them apart, or the result says they cannot.
struct SensorModelOptions {
  bool scale_x = false, scale_y = false, scale_z = false;
  bool incidence_bias = false;
  /// A scale this far from 1, or a bias this large [mm at grazing incidence], more than 3 sigma
  /// from nothing, is reported as a finding.
  double finding_scale = 0.003;
  double finding_bias_mm = 0.02;
  bool Any() const { return scale_x || scale_y || scale_z || incidence_bias; }
};

struct HandEyeOptions {
  double sphere_radius_mm = 12.7;
  /// Coordinates of the sphere centre known beforehand (MCS, mm), e.g. its Z from a touch-off.
  std::array<std::optional<double>, 3> known_centre_mcs;
  /// Points farther than this from the sphere in the per-capture robust fit are dropped before
  /// the joint fit [mm]; 0 = automatic (2.5 robust sigma).
  double capture_inlier_mm = 0.0;
  /// Final trimming of the joint fit: points beyond this many RMS are dropped and the fit is
  /// repeated until the set is stable.
  double trim_sigmas = 3.0;
  /// Lever arm that turns rotations into lengths for the observability test [mm]: about the
  /// working distance.
  double lever_mm = 100.0;
  /// A parameter combination whose standard deviation, with the lever arm, exceeds this is not
  /// determined by the data [mm].
  double max_std_mm = 0.05;
  /// Estimate the sensor's scale and incidence bias as well (none by default: a rigid M).
  SensorModelOptions sensor;
  /// Predict each capture from a solution without it (leave-one-capture-out), so an over-fitted
  /// model shows: its held-out residuals grow where a sound one's do not.
  bool leave_one_out = true;
  void Check() const;
};

/// What one capture contributed.
struct CaptureReport {
  std::string id;
  int points = 0;       ///< given (finite)
  int on_sphere = 0;    ///< its own robust fit's inliers: the sphere's points, not background
  int inliers = 0;      ///< used in the joint fit (of those on the sphere)
  double rms_mm = 0.0;  ///< joint-fit residual RMS of its inliers
  double max_abs_mm = 0.0;
  Vec3 centre_mcs = Vec3::Zero();  ///< its own sphere centre: its points mapped by H_i M
  double fitted_radius_mm = 0.0;   ///< its own free-radius sphere fit (0 for single profiles)
};

/// The parameter order of HandEyeResult::covariance.
inline constexpr std::array<const char*, 9> kHandEyeParameters = {
    "rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm", "cx_mm", "cy_mm", "cz_mm"};

/// The sensor model's parameters with their standard deviations (0 where not estimated).
struct SensorEstimate {
  bool estimated = false;
  Vec3 scale = Vec3::Ones(), scale_std = Vec3::Zero();
  double incidence_bias_mm = 0.0, incidence_bias_std_mm = 0.0;
  /// Correlation of the depth scale and the bias when both are estimated: near +-1 the poses
  /// cannot tell them apart.
  double scale_bias_correlation = 0.0;
  /// For a person to act on: "the probe's depth (z) scale is 2.13 % off its calibration ...".
  std::vector<std::string> findings;
};

/// One capture predicted by the solution of all the others.
struct HeldOutCapture {
  std::string id;
  double rms_mm = 0.0;           ///< its points (the full solution's inliers) against that solution
  double centre_error_mm = 0.0;  ///< where its points put the sphere (radius held) vs that centre
};

struct LeaveOneOut {
  std::vector<HeldOutCapture> captures;  ///< empty when not run
  double rms_mm = 0.0;                   ///< over all held-out points
  double centre_error_rms_mm = 0.0;      ///< over the captures
};

struct HandEyeResult {
  Pose3 flange_from_probe = Pose3::Identity();  ///< M
  Vec3 centre_mcs = Vec3::Zero();               ///< c
  /// sigma^2 (J^T J)^-1 at the solution: rotation of M as a small rotation vector applied in the
  /// flange frame (rad), t_M (mm), c (mm); known centre coordinates have zero rows.
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  double point_rms_mm = 0.0;
  int points_used = 0, points_rejected = 0;
  /// Spread of the per-capture centres about their mean: RMS and largest distance [mm], how well
  /// the captures agree with each other (as ISO 10360-5 judges styli by the range of their
  /// centres). A capture's centre is where its own joint-fit points, mapped by the solution, put
  /// the sphere (radius held).
  double centre_spread_rms_mm = 0.0, centre_spread_max_mm = 0.0;
  /// How far the captures' mean centre lies from c [mm]: the joint fit weighs points, not
  /// centres, so a capture whose centre is weakly fixed (a profile near the equator) pulls its
  /// own centre more than c. Large beside the spread: the captures disagree systematically.
  double centre_mean_offset_mm = 0.0;
  std::vector<CaptureReport> captures;
  SensorEstimate sensor;
  LeaveOneOut leave_one_out;
  std::vector<std::string> warnings;  ///< weakly determined combinations, discarded captures
  int iterations = 0;
};

class HandEyeError : public std::runtime_error {
 public:
  enum class Kind {
    kBadInput,        ///< too few captures or points, non-finite data, bad options
    kUnderDetermined  ///< the poses do not determine M and c; see proposals
  };
  HandEyeError(Kind kind, const std::string& message, std::vector<std::string> proposals = {})
      : std::runtime_error(message), kind_(kind), proposals_(std::move(proposals)) {}
  Kind kind() const { return kind_; }
  /// Captures that would make the problem determined, for a person to act on.
  const std::vector<std::string>& proposals() const { return proposals_; }

 private:
  Kind kind_;
  std::vector<std::string> proposals_;
};

/// Throws HandEyeError; never returns a result with a non-finite number.
HandEyeResult SolveSphereHandEye(const std::vector<SphereCapture>& captures,
                                 const HandEyeOptions& options);

/// A robot's pose as x y z [mm] and W P R [deg], fixed-axis rotations: R = Rz(r) Ry(p) Rx(w).
Pose3 PoseFromXyzWpr(double x, double y, double z, double w_deg, double p_deg, double r_deg);

}  // namespace mlp::calib
