#include "mlp/calib/recheck.h"

#include "mlp/base/units.h"
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

// A capture's points on the sphere: finite, then those its robust free-radius fit keeps.
struct OnSphere {
  geometry::Points3 points;
  std::vector<int> inliers;
  Vec3 centre;  // with the radius held
  double fitted_radius_mm = 0.0;
};

// The sphere a capture sees, in the probe frame: robust free-radius fit to find the sphere and
// its apparent radius, then the centre with the radius held.
OnSphere FindSphere(const RecheckCapture& c, double radius) {
  OnSphere s;
  s.points.resize(3, c.points_in_probe.cols());
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < c.points_in_probe.cols(); ++i) {
    if (c.points_in_probe.col(i).allFinite()) s.points.col(n++) = c.points_in_probe.col(i);
  }
  s.points.conservativeResize(3, n);
  if (n < kMinPoints) Bad("capture " + c.id + ": " + std::to_string(n) + " points on the sphere");
  try {
    const auto fit = geometry::FitSphereRobust(s.points);
    s.fitted_radius_mm = fit.fit.shape.radius;
    s.inliers = fit.inliers;
    s.centre = CentreWithRadius(s.points, s.inliers, radius, fit.fit.shape.center);
  } catch (const geometry::GeometryError& e) {
    Bad("capture " + c.id + ": " + e.what());
  }
  return s;
}

struct DepthScale {
  std::vector<Vec3> centres;  // of the readings corrected by the scale
  double scale = 1.0, std = 0.0;
};

// One depth scale s shared by the captures and each capture's centre c_i, the radius held:
// |(x, y, s z) - c_i| = R (Gauss-Newton on the normal equations; 3n + 1 unknowns, one row per
// point). On a cap seen along z the scale changes the cap's depth for its width by the factor
// s, which no centre absorbs; s is about the probe origin, as the hand-eye's sensor model
// (hand_eye.h, SensorModelOptions), so a 1 % scale also moves a centre 100 mm away by 1 mm.
DepthScale FitDepthScale(const std::vector<OnSphere>& spheres, double radius) {
  const auto n = static_cast<Eigen::Index>(spheres.size());
  const Eigen::Index u = 3 * n + 1;
  DepthScale d;
  for (const OnSphere& s : spheres) d.centres.push_back(s.centre);
  Eigen::MatrixXd jtj(u, u);
  double sum_sq = 0.0;
  int rows = 0;
  for (int step = 0; step < kGaussNewtonSteps; ++step) {
    jtj.setZero();
    Eigen::VectorXd jtr = Eigen::VectorXd::Zero(u);
    sum_sq = 0.0, rows = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const OnSphere& s = spheres[static_cast<size_t>(i)];
      for (int k : s.inliers) {
        const Vec3 p = s.points.col(k);
        const Vec3 w = Vec3(p.x(), p.y(), d.scale * p.z()) - d.centres[static_cast<size_t>(i)];
        const double dist = w.norm();
        if (!(dist > 0)) continue;
        Eigen::Matrix<double, 4, 1> j;
        j << -w / dist, w.z() / dist * p.z();
        const double r = dist - radius;
        const Eigen::Index at[4] = {3 * i, 3 * i + 1, 3 * i + 2, u - 1};
        for (int a = 0; a < 4; ++a) {
          jtr(at[a]) += j(a) * r;
          for (int b = 0; b < 4; ++b) jtj(at[a], at[b]) += j(a) * j(b);
        }
        sum_sq += r * r, ++rows;
      }
    }
    const Eigen::VectorXd dx = -jtj.ldlt().solve(jtr);
    if (!dx.allFinite()) Bad("the depth scale of the readings could not be fitted");
    for (Eigen::Index i = 0; i < n; ++i) d.centres[static_cast<size_t>(i)] += dx.segment<3>(3 * i);
    d.scale += dx(u - 1);
    if (dx.norm() < 1e-12) break;
  }
  const double sigma2 = sum_sq / static_cast<double>(std::max<Eigen::Index>(1, rows - u));
  d.std = std::sqrt(sigma2 * jtj.ldlt().solve(Eigen::VectorXd::Unit(u, u - 1))(u - 1));
  return d;
}

struct State {
  Mat3 rotation;
  Vec3 translation, centre;
  Vec3 Residual(const Pose3& h, const Vec3& q) const {
    return h * (rotation * q + translation) - centre;
  }
};

void CheckCaptureCount(int n, const RecheckOptions& o) {
  if (n == 0) Bad("no capture of the sphere");
  if (o.sphere_moved && n < 3) {
    throw HandEyeError(Kind::kUnderDetermined,
                       "with the sphere re-mounted, its position and the probe's change can be "
                       "told apart only from three orientations or more; " +
                           std::to_string(n) + " measured",
                       {"measure the sphere at three or more spindle orientations (M19 0, 120, "
                        "240 degrees) or head orientations"});
  }
}

// Unknowns (rotation x lever | offset | centre shift); one orientation: the offset only.
std::vector<int> ActiveUnknowns(int n, bool sphere_moved) {
  std::vector<int> active;
  if (n >= 2) active = {0, 1, 2};
  for (int k = 3; k < 6; ++k) active.push_back(k);
  if (sphere_moved) active.insert(active.end(), {6, 7, 8});
  return active;
}

// Gauss-Newton on h_i (R q_i + t) = c over the active unknowns, each step through the SVD:
// directions the orientations do not determine are kept from the original and listed.
State SolveMountChange(const std::vector<RecheckCapture>& captures,
                       const std::vector<Vec3>& q,
                       const std::vector<int>& active,
                       const State& original,
                       double lever_mm,
                       std::vector<detail::Vec9>* undetermined) {
  const auto n = static_cast<Eigen::Index>(captures.size());
  const int m = static_cast<int>(active.size());
  State s = original;
  for (int step = 0; step < kGaussNewtonSteps; ++step) {
    Eigen::MatrixXd j(3 * n, m);
    Eigen::VectorXd e(3 * n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Pose3& h = captures[static_cast<size_t>(i)].mcs_from_flange;
      const Vec3 a = s.rotation * q[static_cast<size_t>(i)];
      Eigen::Matrix<double, 3, 9> full;
      full << -h.linear() * Skew(a) / lever_mm, h.linear(), -Mat3::Identity();
      for (int c = 0; c < m; ++c)
        j.block<3, 1>(3 * i, c) = full.col(active[static_cast<size_t>(c)]);
      e.segment<3>(3 * i) = s.Residual(h, q[static_cast<size_t>(i)]);
    }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinU | Eigen::ComputeThinV);
    const Eigen::VectorXd& sv = svd.singularValues();
    Eigen::VectorXd dx = Eigen::VectorXd::Zero(m);
    undetermined->clear();
    for (int k = 0; k < sv.size(); ++k) {
      if (sv(k) > kRankTolerance * sv(0)) {
        dx -= svd.matrixV().col(k) * (svd.matrixU().col(k).dot(e) / sv(k));
      } else {
        detail::Vec9 v = detail::Vec9::Zero();
        for (int c = 0; c < m; ++c) v(active[static_cast<size_t>(c)]) = svd.matrixV()(c, k);
        undetermined->push_back(v);
      }
    }
    detail::Vec9 full_dx = detail::Vec9::Zero();
    for (int c = 0; c < m; ++c) full_dx(active[static_cast<size_t>(c)]) = dx(c);
    s.rotation = Exp(full_dx.head<3>() / lever_mm) * s.rotation;
    s.translation += full_dx.segment<3>(3);
    s.centre += full_dx.tail<3>();
  }
  return s;
}

// The change found against the original, and the centres' disagreement before and after it.
void FillChange(const std::vector<RecheckCapture>& captures,
                const std::vector<Vec3>& q,
                const State& original,
                const State& s,
                RecheckResult* result) {
  result->flange_from_probe.linear() = s.rotation;
  result->flange_from_probe.translation() = s.translation;
  result->centre_mcs = s.centre;
  result->offset_in_flange_mm = s.translation - original.translation;
  const Eigen::AngleAxisd change(s.rotation * original.rotation.transpose());
  result->rotation_in_flange_rad = change.axis() * change.angle();
  result->centre_shift_mm = s.centre - original.centre;
  double ss = 0.0;
  for (size_t i = 0; i < captures.size(); ++i) {
    const Pose3& h = captures[i].mcs_from_flange;
    result->residual_before_mm.push_back(original.Residual(h, q[i]).norm());
    const double after = s.Residual(h, q[i]).norm();
    result->residual_after_mm.push_back(after);
    ss += after * after;
  }
  result->residual_after_rms_mm = std::sqrt(ss / double(captures.size()));
}

// Why a quick fix will not do (empty: it will), the first limit passed.
std::string WhyFullCalibration(const RecheckResult& r,
                               const DepthScale& depth,
                               bool scale_changed,
                               const RecheckOptions& o) {
  const double turned_deg = r.rotation_in_flange_rad.norm() * base::kDegPerRad;
  std::ostringstream why;
  why.precision(4);
  if (scale_changed) {
    why << "the probe's depth scale changed by " << 100.0 * (depth.scale - 1.0)
        << " % (its readings fit the sphere x" << depth.scale << " +- " << depth.std << ", limit "
        << 100.0 * o.max_depth_scale_change
        << " %): its camera/projector calibration no longer holds; recalibrate the probe";
  } else if (r.offset_in_flange_mm.norm() > o.max_offset_mm) {
    why << "the mount moved " << r.offset_in_flange_mm.norm() << " mm (quick fix limit "
        << o.max_offset_mm << " mm)";
  } else if (turned_deg > o.max_rotation_deg) {
    why << "the mount turned " << turned_deg << " degrees (quick fix limit " << o.max_rotation_deg
        << " degrees)";
  } else if (r.residual_after_rms_mm > o.max_residual_mm) {
    why << "after the best rigid correction the sphere centres still disagree by "
        << r.residual_after_rms_mm * 1e3 << " um RMS (limit " << o.max_residual_mm * 1e3
        << " um): the change is not a rigid shift of the mount";
  }
  return why.str();
}

}  // namespace

void RecheckOptions::Check() const {
  if (!(sphere_radius_mm > 0)) Bad("sphere radius must be > 0");
  if (!original_flange_from_probe.matrix().allFinite() || !original_centre_mcs.allFinite())
    Bad("the original calibration is not finite");
  if (!(max_offset_mm > 0 && max_rotation_deg > 0 && max_residual_mm > 0 && lever_mm > 0 &&
        max_depth_scale_change > 0))
    Bad("limits must be > 0");
}

RecheckResult Recheck(const std::vector<RecheckCapture>& captures, const RecheckOptions& o) {
  o.Check();
  const int n = static_cast<int>(captures.size());
  CheckCaptureCount(n, o);
  std::vector<Vec3> q;
  std::vector<OnSphere> spheres;
  RecheckResult result;
  for (const RecheckCapture& c : captures) {
    spheres.push_back(FindSphere(c, o.sphere_radius_mm));
    q.push_back(spheres.back().centre);
    result.apparent_radius_change_mm += (spheres.back().fitted_radius_mm - o.sphere_radius_mm) / n;
  }
  // A changed depth scale is the camera/projector's calibration, not the mount: when it is a
  // finding the centres are taken from the corrected readings, so it is not folded into an
  // offset, and it is reported as what it is.
  const DepthScale depth = FitDepthScale(spheres, o.sphere_radius_mm);
  result.depth_scale = depth.scale, result.depth_scale_std = depth.std;
  const double scale_change = std::abs(depth.scale - 1.0);
  const bool scale_changed =
      scale_change > o.max_depth_scale_change && scale_change > 3.0 * depth.std;
  if (scale_changed) q = depth.centres;

  const State original{o.original_flange_from_probe.linear(),
                       o.original_flange_from_probe.translation(), o.original_centre_mcs};
  std::vector<detail::Vec9> undetermined;
  const State s = SolveMountChange(captures, q, ActiveUnknowns(n, o.sphere_moved), original,
                                   o.lever_mm, &undetermined);
  for (const auto& v : undetermined)
    result.not_determined.push_back(detail::Describe(v) + " (kept from the original)");
  if (n == 1)
    result.not_determined.push_back("M's rotation (one orientation: the correction is an offset)");
  FillChange(captures, q, original, s, &result);
  result.reason = WhyFullCalibration(result, depth, scale_changed, o);
  result.full_calibration_required = !result.reason.empty();
  if (!result.flange_from_probe.matrix().allFinite() || !result.centre_mcs.allFinite())
    Bad("the correction did not converge");
  return result;
}

}  // namespace mlp::calib
