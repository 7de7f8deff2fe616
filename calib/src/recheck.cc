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
  // Two orientations: six equations for the mount's turn and shift, which they cannot tell
  // apart; the truncated solve read an 80 um shift as a 61 arcsec turn and kept the shift's X
  // and Y from the original, 34 um off in every one of 30 seeded draws (one orientation: 0.14
  // um, three: 2.8 um median). Refused rather than stored.
  if (n == 2)
    throw HandEyeError(Kind::kUnderDetermined,
                       "two orientations cannot tell a shift of the mount from a turn of it (a "
                       "shift would be stored as a turn)",
                       {"measure the sphere at one orientation for the offset alone, or at three "
                        "or more (M19 0, 120, 240 degrees) for offset and turn"});
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

// One Gauss-Newton step dx (over the active unknowns) from the Jacobian and the residuals
// through the SVD: a direction whose singular value is below `min_singular` is not determined
// by the views; it is left out (kept from the original) and listed in `undetermined`.
Eigen::VectorXd TruncatedStep(const Eigen::MatrixXd& j,
                              const Eigen::VectorXd& e,
                              const std::vector<int>& active,
                              double min_singular,
                              std::vector<detail::Vec9>* undetermined) {
  const int m = static_cast<int>(active.size());
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(j, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd& sv = svd.singularValues();

  Eigen::VectorXd dx = Eigen::VectorXd::Zero(m);
  undetermined->clear();
  for (int k = 0; k < sv.size(); ++k) {
    if (sv(k) > kRankTolerance * sv(0) && sv(k) > min_singular) {
      dx -= svd.matrixV().col(k) * (svd.matrixU().col(k).dot(e) / sv(k));
    } else {
      detail::Vec9 v = detail::Vec9::Zero();
      for (int c = 0; c < m; ++c) v(active[static_cast<size_t>(c)]) = svd.matrixV()(c, k);
      undetermined->push_back(v);
    }
  }
  return dx;
}

// The step's active unknowns applied: the rotation (scaled by the lever) on the left of M's.
void Apply(const Eigen::VectorXd& dx, const std::vector<int>& active, double lever_mm, State* s) {
  detail::Vec9 full_dx = detail::Vec9::Zero();
  for (size_t c = 0; c < active.size(); ++c) full_dx(active[c]) = dx(static_cast<Eigen::Index>(c));
  s->rotation = Exp(full_dx.head<3>() / lever_mm) * s->rotation;
  s->translation += full_dx.segment<3>(3);
  s->centre += full_dx.tail<3>();
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
    Apply(TruncatedStep(j, e, active, 0.0, undetermined), active, lever_mm, &s);
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
std::string WhyFullCalibration(
    const RecheckResult& r,
    const DepthScale& depth,
    bool scale_changed,
    const RecheckOptions& o,
    const char* what = "sphere centres",
    const char* meaning = "the change is not a rigid shift of the mount") {
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
    why << "after the best rigid correction the " << what << " still disagree by "
        << r.residual_after_rms_mm * 1e3 << " um RMS (limit " << o.max_residual_mm * 1e3
        << " um): " << meaning;
  }
  return why.str();
}

// ---- The part as the artefact -------------------------------------------------------------

// Points per capture in the part's fit: enough that each view's offset is known to far below
// the probe's noise; more only cost time (a bore view holds 25,000).
constexpr int kPartPointsPerCapture = 2000;
// A direction known worse than this (1 sigma) is kept from the original.
constexpr double kPartDeterminedMm = 0.0005;

Vec3 Gradient(const PartSurface& s, const Vec3& x) {
  Vec3 u = s.direction_mcs.normalized();
  if (s.kind == PartSurface::Kind::kPlane) return u;
  const Vec3 d = x - s.point_mcs, radial = d - d.dot(u) * u;
  return radial.norm() > 0 ? Vec3(radial.normalized()) : Vec3::Zero();
}

// Every k-th finite point of each capture, at most kPartPointsPerCapture.
std::vector<geometry::Points3> Thinned(const std::vector<RecheckCapture>& captures) {
  std::vector<geometry::Points3> out;
  for (const RecheckCapture& c : captures) {
    std::vector<Eigen::Index> finite;
    for (Eigen::Index i = 0; i < c.points_in_probe.cols(); ++i)
      if (c.points_in_probe.col(i).allFinite()) finite.push_back(i);
    if (static_cast<int>(finite.size()) < kMinPoints)
      Bad("capture " + c.id + ": " + std::to_string(finite.size()) + " points on the part");
    const size_t every = (finite.size() + kPartPointsPerCapture - 1) / kPartPointsPerCapture;
    geometry::Points3 p(3, static_cast<Eigen::Index>((finite.size() + every - 1) / every));
    for (size_t k = 0; k < finite.size(); k += every)
      p.col(static_cast<Eigen::Index>(k / every)) = c.points_in_probe.col(finite[k]);
    out.push_back(std::move(p));
  }
  return out;
}

// Each capture's points' mean signed distance from the surface with the mount of `s`.
std::vector<double> MeanDistances(const std::vector<RecheckCapture>& captures,
                                  const std::vector<geometry::Points3>& points,
                                  const PartSurface& surface,
                                  const State& s) {
  std::vector<double> mean;
  for (size_t i = 0; i < captures.size(); ++i) {
    double sum = 0.0;
    for (Eigen::Index k = 0; k < points[i].cols(); ++k)
      sum += surface.Distance(captures[i].mcs_from_flange *
                              (s.rotation * points[i].col(k) + s.translation));
    mean.push_back(sum / static_cast<double>(points[i].cols()));
  }
  return mean;
}

// Gauss-Newton on distance(h_i (R p + t)) = 0 over the mount's six unknowns, each step through
// the SVD; the noise level that decides what is determined is the points' scatter about their
// own capture's mean (a view's mean offset is what the change moves, not noise).
State SolvePartChange(const std::vector<RecheckCapture>& captures,
                      const std::vector<geometry::Points3>& points,
                      const PartSurface& surface,
                      const State& original,
                      double lever_mm,
                      std::vector<detail::Vec9>* undetermined) {
  const std::vector<int> active = {0, 1, 2, 3, 4, 5};
  Eigen::Index rows = 0;
  for (const auto& p : points) rows += p.cols();
  State s = original;
  for (int step = 0; step < kGaussNewtonSteps; ++step) {
    Eigen::MatrixXd j(rows, 6);
    Eigen::VectorXd e(rows);
    double scatter = 0.0;
    Eigen::Index row = 0;
    for (size_t i = 0; i < captures.size(); ++i) {
      const Pose3& h = captures[i].mcs_from_flange;
      const Eigen::Index first = row;
      for (Eigen::Index k = 0; k < points[i].cols(); ++k, ++row) {
        const Vec3 a = s.rotation * points[i].col(k), x = h * (a + s.translation);
        const Eigen::RowVector3d g = Gradient(surface, x).transpose() * h.linear();
        j.block<1, 3>(row, 0) = -g * Skew(a) / lever_mm;
        j.block<1, 3>(row, 3) = g;
        e(row) = surface.Distance(x);
      }
      const auto view = e.segment(first, row - first);
      scatter += (view.array() - view.mean()).square().sum();
    }
    const double sigma =
        std::sqrt(scatter / static_cast<double>(std::max<Eigen::Index>(1, rows - 6)));
    Apply(TruncatedStep(j, e, active, sigma / kPartDeterminedMm, undetermined), active, lever_mm,
          &s);
  }
  return s;
}

}  // namespace

double PartSurface::Distance(const Vec3& x) const {
  const Vec3 u = direction_mcs.normalized(), d = x - point_mcs;
  if (kind == Kind::kPlane) return d.dot(u);
  return (d - d.dot(u) * u).norm() - radius_mm;
}

RecheckResult RecheckOnPart(const std::vector<RecheckCapture>& captures,
                            const PartSurface& surface,
                            const RecheckOptions& o) {
  o.Check();
  if (captures.empty()) Bad("no capture of the part");
  if (!surface.point_mcs.allFinite() || !(surface.direction_mcs.norm() > 0) ||
      !surface.direction_mcs.allFinite() ||
      (surface.kind == PartSurface::Kind::kCylinder && !(surface.radius_mm > 0)))
    Bad("the part's reference surface is not one");
  const std::vector<geometry::Points3> points = Thinned(captures);
  const State original{o.original_flange_from_probe.linear(),
                       o.original_flange_from_probe.translation(), o.original_centre_mcs};
  std::vector<detail::Vec9> undetermined;
  const State s = SolvePartChange(captures, points, surface, original, o.lever_mm, &undetermined);
  RecheckResult result;
  for (const auto& v : undetermined)
    result.not_determined.push_back(detail::Describe(v) + " (kept from the original)");
  result.flange_from_probe.linear() = s.rotation;
  result.flange_from_probe.translation() = s.translation;
  result.centre_mcs = original.centre;
  result.offset_in_flange_mm = s.translation - original.translation;
  const Eigen::AngleAxisd change(s.rotation * original.rotation.transpose());
  result.rotation_in_flange_rad = change.axis() * change.angle();
  const std::vector<double> before = MeanDistances(captures, points, surface, original);
  const std::vector<double> after = MeanDistances(captures, points, surface, s);
  double ss = 0.0, sum = 0.0;
  for (size_t i = 0; i < captures.size(); ++i) {
    result.residual_before_mm.push_back(std::abs(before[i]));
    result.residual_after_mm.push_back(std::abs(after[i]));
    ss += after[i] * after[i], sum += before[i];
  }
  const double n = static_cast<double>(captures.size());
  result.residual_after_rms_mm = std::sqrt(ss / n);
  // Before the correction: views all round a bore cancel a sideways move, not a change of the
  // depth the probe reads, which a mount offset along the views would otherwise take up.
  result.apparent_radius_change_mm = sum / n;
  result.reason =
      WhyFullCalibration(result, DepthScale{}, false, o, "captures and the part",
                         "the part does not see all of the change, or it is not a rigid shift "
                         "of the mount; recalibrate on the sphere");
  result.full_calibration_required = !result.reason.empty();
  if (!result.flange_from_probe.matrix().allFinite()) Bad("the correction did not converge");
  return result;
}

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
