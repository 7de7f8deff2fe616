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
  void Check() const;
};

/// What one capture contributed.
struct CaptureReport {
  std::string id;
  int points = 0;       ///< given (finite)
  int inliers = 0;      ///< used in the joint fit
  double rms_mm = 0.0;  ///< joint-fit residual RMS of its inliers
  double max_abs_mm = 0.0;
  Vec3 centre_mcs = Vec3::Zero();  ///< its own sphere centre mapped by H_i M (from its points)
  double fitted_radius_mm = 0.0;   ///< its own free-radius sphere fit (0 for single profiles)
};

/// The parameter order of HandEyeResult::covariance.
inline constexpr std::array<const char*, 9> kHandEyeParameters = {
    "rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm", "cx_mm", "cy_mm", "cz_mm"};

struct HandEyeResult {
  Pose3 flange_from_probe = Pose3::Identity();  ///< M
  Vec3 centre_mcs = Vec3::Zero();               ///< c
  /// sigma^2 (J^T J)^-1 at the solution: rotation of M as a small rotation vector applied in the
  /// flange frame (rad), t_M (mm), c (mm); known centre coordinates have zero rows.
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  double point_rms_mm = 0.0;
  int points_used = 0, points_rejected = 0;
  /// Spread of the per-capture centres around c: RMS and largest distance [mm].
  double centre_spread_rms_mm = 0.0, centre_spread_max_mm = 0.0;
  std::vector<CaptureReport> captures;
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
