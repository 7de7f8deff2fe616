#include "mlp/calib/recheck.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/robust.h"

#include <cmath>
#include <sstream>

#include "describe.h"
#include <Eigen/Dense>

namespace mlp::calib {
namespace {

using Kind = HandEyeError::Kind;
using Mat3 = Eigen::Matrix3d;

constexpr int kMinPoints = 20;
constexpr int kGaussNewtonSteps = 8;
// A direction whose singular value is below this fraction of the largest is not determined by
// the orientations measured (exact degeneracy, e.g. one orientation for a rotation).
constexpr double kRankTolerance = 1e-7;

[[noreturn]] void Bad(const std::string& m) { throw HandEyeError(Kind::kBadInput, m); }

Mat3 Skew(const Vec3& v) {
  Mat3 s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

Mat3 Exp(const Vec3& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Mat3::Identity();
}

// Centre of a sphere of known radius through `points` (Gauss-Newton from `start`). On a cap the
// free-radius fit trades the radius against the centre along the line of sight (a micrometre of
// radius moves the centre by about as much); the radius is known here, so it is held. The
// geometry layer has no fixed-radius sphere fit; three unknowns need no more than this.
Vec3 CentreWithRadius(const geometry::Points3& points,
                      const std::vector<int>& inliers,
                      double radius,
                      Vec3 centre) {
  for (int step = 0; step < 10; ++step) {
    Mat3 jtj = Mat3::Zero();
    Vec3 jtr = Vec3::Zero();
    for (int i : inliers) {
      const Vec3 d = centre - points.col(i);
      const double dist = d.norm();
      if (dist <= 0) continue;
      const Vec3 g = d / dist;  // d(dist)/d(centre)
      jtj += g * g.transpose();
      jtr += g * (dist - radius);
    }
    const Vec3 delta = -jtj.ldlt().solve(jtr);
    centre += delta;
    if (delta.norm() < 1e-12) break;
  }
  return centre;
}

// The sphere centre a capture sees, in the probe frame: robust free-radius fit to find the
// sphere and its apparent radius, then the centre with the radius held.
Vec3 CentreInProbe(const RecheckCapture& c, double radius, double* fitted_radius) {
  geometry::Points3 finite(3, c.points_in_probe.cols());
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < c.points_in_probe.cols(); ++i) {
    if (c.points_in_probe.col(i).allFinite()) finite.col(n++) = c.points_in_probe.col(i);
  }
  finite.conservativeResize(3, n);
  if (n < kMinPoints) Bad("capture " + c.id + ": " + std::to_string(n) + " points on the sphere");
  try {
    const auto fit = geometry::FitSphereRobust(finite);
    *fitted_radius = fit.fit.shape.radius;
    return CentreWithRadius(finite, fit.inliers, radius, fit.fit.shape.center);
  } catch (const geometry::GeometryError& e) {
    Bad("capture " + c.id + ": " + e.what());
  }
}

struct State {
  Mat3 rotation;
  Vec3 translation, centre;
  Vec3 Residual(const Pose3& h, const Vec3& q) const {
    return h * (rotation * q + translation) - centre;
  }
};

}  // namespace

void RecheckOptions::Check() const {
  if (!(sphere_radius_mm > 0)) Bad("sphere radius must be > 0");
  if (!original_flange_from_probe.matrix().allFinite() || !original_centre_mcs.allFinite())
    Bad("the original calibration is not finite");
  if (!(max_offset_mm > 0 && max_rotation_deg > 0 && max_residual_mm > 0 && lever_mm > 0))
    Bad("limits must be > 0");
}

RecheckResult Recheck(const std::vector<RecheckCapture>& captures, const RecheckOptions& o) {
  o.Check();
  if (captures.empty()) Bad("no capture of the sphere");
  const int n = static_cast<int>(captures.size());
  if (o.sphere_moved && n < 3) {
    throw HandEyeError(Kind::kUnderDetermined,
                       "with the sphere re-mounted, its position and the probe's change can be "
                       "told apart only from three orientations or more; " +
                           std::to_string(n) + " measured",
                       {"measure the sphere at three or more spindle orientations (M19 0, 120, "
                        "240 degrees) or head orientations"});
  }
  std::vector<Vec3> q(static_cast<size_t>(n));
  RecheckResult result;
  for (int i = 0; i < n; ++i) {
    double radius = 0.0;
    q[static_cast<size_t>(i)] =
        CentreInProbe(captures[static_cast<size_t>(i)], o.sphere_radius_mm, &radius);
    result.apparent_radius_change_mm += (radius - o.sphere_radius_mm) / n;
  }
  // Unknowns (rotation x lever | offset | centre shift); one orientation: the offset only.
  std::vector<int> active;
  if (n >= 2) active = {0, 1, 2};
  for (int k = 3; k < 6; ++k) active.push_back(k);
  if (o.sphere_moved) active.insert(active.end(), {6, 7, 8});
  const int m = static_cast<int>(active.size());

  const State original{o.original_flange_from_probe.linear(),
                       o.original_flange_from_probe.translation(), o.original_centre_mcs};
  State s = original;
  std::vector<detail::Vec9> undetermined;
  for (int step = 0; step < kGaussNewtonSteps; ++step) {
    Eigen::MatrixXd j(3 * n, m);
    Eigen::VectorXd e(3 * n);
    for (int i = 0; i < n; ++i) {
      const Pose3& h = captures[static_cast<size_t>(i)].mcs_from_flange;
      const Vec3 a = s.rotation * q[static_cast<size_t>(i)];
      Eigen::Matrix<double, 3, 9> full;
      full << -h.linear() * Skew(a) / o.lever_mm, h.linear(), -Mat3::Identity();
      for (int c = 0; c < m; ++c)
        j.block<3, 1>(3 * i, c) = full.col(active[static_cast<size_t>(c)]);
      e.segment<3>(3 * i) = s.Residual(h, q[static_cast<size_t>(i)]);
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd sv = svd.singularValues();
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(m);
    undetermined.clear();
    for (int k = 0; k < sv.size(); ++k) {
      if (sv(k) > kRankTolerance * sv(0)) {
        dx -= svd.matrixV().col(k) * (svd.matrixU().col(k).dot(e) / sv(k));
      } else {
        detail::Vec9 v = detail::Vec9::Zero();
        for (int c = 0; c < m; ++c) v(active[static_cast<size_t>(c)]) = svd.matrixV()(c, k);
        undetermined.push_back(v);
      }
    }
    detail::Vec9 full_dx = detail::Vec9::Zero();
    for (int c = 0; c < m; ++c) full_dx(active[static_cast<size_t>(c)]) = dx(c);
    s.rotation = Exp(full_dx.head<3>() / o.lever_mm) * s.rotation;
    s.translation += full_dx.segment<3>(3);
    s.centre += full_dx.tail<3>();
  }
  for (const auto& v : undetermined)
    result.not_determined.push_back(detail::Describe(v) + " (kept from the original)");
  if (n == 1)
    result.not_determined.push_back("M's rotation (one orientation: the correction is an offset)");

  result.flange_from_probe.linear() = s.rotation;
  result.flange_from_probe.translation() = s.translation;
  result.centre_mcs = s.centre;
  result.offset_in_flange_mm = s.translation - original.translation;
  const Eigen::AngleAxisd change(s.rotation * original.rotation.transpose());
  result.rotation_in_flange_rad = change.axis() * change.angle();
  result.centre_shift_mm = s.centre - original.centre;
  double ss = 0.0;
  for (int i = 0; i < n; ++i) {
    const Pose3& h = captures[static_cast<size_t>(i)].mcs_from_flange;
    result.residual_before_mm.push_back(original.Residual(h, q[static_cast<size_t>(i)]).norm());
    const double after = s.Residual(h, q[static_cast<size_t>(i)]).norm();
    result.residual_after_mm.push_back(after);
    ss += after * after;
  }
  result.residual_after_rms_mm = std::sqrt(ss / n);

  std::ostringstream why;
  why.precision(4);
  if (result.offset_in_flange_mm.norm() > o.max_offset_mm) {
    why << "the mount moved " << result.offset_in_flange_mm.norm() << " mm (quick fix limit "
        << o.max_offset_mm << " mm)";
  } else if (change.angle() * 180.0 / M_PI > o.max_rotation_deg) {
    why << "the mount turned " << change.angle() * 180.0 / M_PI << " degrees (quick fix limit "
        << o.max_rotation_deg << " degrees)";
  } else if (result.residual_after_rms_mm > o.max_residual_mm) {
    why << "after the best rigid correction the sphere centres still disagree by "
        << result.residual_after_rms_mm * 1e3 << " um RMS (limit " << o.max_residual_mm * 1e3
        << " um): the change is not a rigid shift of the mount";
  }
  result.reason = why.str();
  result.full_calibration_required = !result.reason.empty();
  if (!result.flange_from_probe.matrix().allFinite() || !result.centre_mcs.allFinite())
    Bad("the correction did not converge");
  return result;
}

}  // namespace mlp::calib
