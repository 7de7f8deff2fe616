#include "mlp/calib/hand_eye.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <cmath>
#include <sstream>

#include "describe.h"
#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace mlp::calib {
namespace {

using detail::Describe;
using Kind = HandEyeError::Kind;
using Mat3 = Eigen::Matrix3d;
using detail::Vec9;
using Mat9 = Eigen::Matrix<double, 9, 9>;

constexpr int kMinCaptures = 3;
constexpr int kMinPointsPerCapture = 20;
// A profile whose circle is wider than the sphere by more than this is not a cut of it.
constexpr double kProfileRadiusSlack = 0.05;
// Fixed MSAC thresholds tried on a profile whose automatic robust fit fails, as fractions of the
// sphere radius (0.5 and 0.25 mm on a 25.4 mm ball).
constexpr double kProfileThresholds[] = {0.02, 0.01};
// Sign patterns of single profiles tried exhaustively up to this many captures, greedily beyond.
constexpr int kMaxExhaustiveProfiles = 12;
// Closed-form starts refined by the joint fit when single profiles leave the sides open.
constexpr int kStartsRefined = 16;
// Before iterating, only a combination determined worse than this many times the limit (a null
// space of the problem, as with translations only) is refused.
constexpr double kStructuralFactor = 1e3;
constexpr int kMaxTrimRounds = 8;
// Trimming never cuts below this [mm]: points within it are noise, not outliers.
constexpr double kTrimFloorMm = 1e-4;

[[noreturn]] void Bad(const std::string& message) { throw HandEyeError(Kind::kBadInput, message); }

// One capture after its own robust fit: the points on the sphere and its centre candidates.
struct Prepared {
  const SphereCapture* capture = nullptr;
  geometry::Points3 points;           // finite points
  std::vector<Vec3> centre_in_probe;  // 1 candidate, or 2 (either side of a profile's plane)
  std::vector<int> inliers;           // into `points`, from the capture's own fit
  double fit_rms_mm = 0.0;
  double fitted_radius_mm = 0.0;
};

geometry::Points3 FinitePoints(const geometry::Points3& in) {
  geometry::Points3 out(3, in.cols());
  Eigen::Index n = 0;
  for (Eigen::Index i = 0; i < in.cols(); ++i) {
    if (in.col(i).allFinite()) out.col(n++) = in.col(i);
  }
  out.conservativeResize(3, n);
  return out;
}

std::optional<Prepared> Prepare(const SphereCapture& c,
                                const HandEyeOptions& o,
                                std::vector<std::string>* warnings) {
  Prepared p;
  p.capture = &c;
  p.points = FinitePoints(c.points_in_probe);
  if (p.points.cols() < kMinPointsPerCapture) {
    warnings->push_back("capture " + c.id + " skipped: " + std::to_string(p.points.cols()) +
                        " points, at least " + std::to_string(kMinPointsPerCapture) + " needed");
    return std::nullopt;
  }
  geometry::RobustOptions ro;
  ro.inlier_threshold_mm = o.capture_inlier_mm;
  try {
    if (c.single_profile) {
      const double r = o.sphere_radius_mm;
      auto fit = geometry::FitCircle3Robust(p.points, ro);
      // The automatic threshold (LMedS) breaks down beyond 50 % outliers, as in a profile that
      // sees more table and spatter than sphere; the consensus then takes a circle larger than
      // the sphere, which cannot be a cut of it. MSAC with fixed thresholds, from a few percent
      // of the radius down, finds the arc instead.
      for (double fraction : kProfileThresholds) {
        if (o.capture_inlier_mm > 0 || fit.fit.shape.radius <= r * (1.0 + kProfileRadiusSlack))
          break;
        ro.inlier_threshold_mm = fraction * r;
        fit = geometry::FitCircle3Robust(p.points, ro);
      }
      const geometry::Circle3& circle = fit.fit.shape;
      if (circle.radius > r * (1.0 + kProfileRadiusSlack)) {
        std::ostringstream m;
        m << "capture " << c.id << " skipped: its profile is a circle of radius " << circle.radius
          << " mm, larger than the sphere's " << r << " mm";
        warnings->push_back(m.str());
        return std::nullopt;
      }
      const double h = std::sqrt(std::max(0.0, r * r - circle.radius * circle.radius));
      p.centre_in_probe = {circle.center + h * circle.normal, circle.center - h * circle.normal};
      p.inliers = fit.inliers;
      p.fit_rms_mm = fit.fit.stats.rms;
    } else {
      const auto fit = geometry::FitSphereRobust(p.points, ro);
      p.centre_in_probe = {fit.fit.shape.center};
      p.inliers = fit.inliers;
      p.fit_rms_mm = fit.fit.stats.rms;
      p.fitted_radius_mm = fit.fit.shape.radius;
    }
  } catch (const geometry::GeometryError& e) {
    warnings->push_back("capture " + c.id + " skipped: its own fit failed (" + e.what() + ")");
    return std::nullopt;
  }
  return p;
}

// ------------------------------------------------------------------ closed form

struct Linear {
  Mat3 rotation = Mat3::Identity();
  Vec3 translation = Vec3::Zero();
  Vec3 centre = Vec3::Zero();
  double residual = 0.0;  // RMS of H_i M q_i - c over captures [mm]
};

// Columns of the known centre coordinates are moved to the right-hand side.
Eigen::VectorXd SolveMinNorm(const Eigen::MatrixXd& a, const Eigen::VectorXd& b) {
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(a);
  cod.setThreshold(1e-10);
  return cod.solve(b);
}

Mat3 NearestRotation(const Mat3& m) {
  Eigen::JacobiSVD<Mat3> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 d = Mat3::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// H_i (R q_i + t) = c for every capture, in the unknowns (R: 9 | t: 3 | free centre coords).
// With R given (`fixed_rotation`), only t and c.
Linear SolveLinear(const std::vector<Pose3>& h,
                   const std::vector<Vec3>& q,
                   const HandEyeOptions& o,
                   const Mat3* fixed_rotation) {
  const int n = static_cast<int>(h.size());
  std::vector<int> free_axes;
  for (int k = 0; k < 3; ++k) {
    if (!o.known_centre_mcs[static_cast<size_t>(k)]) free_axes.push_back(k);
  }
  const int nr = fixed_rotation ? 0 : 9, nc = static_cast<int>(free_axes.size());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, nr + 3 + nc);
  Eigen::VectorXd b(3 * n);
  for (int i = 0; i < n; ++i) {
    const Mat3 rh = h[static_cast<size_t>(i)].linear();
    Vec3 rhs = -h[static_cast<size_t>(i)].translation();
    if (fixed_rotation) {
      rhs -= rh * (*fixed_rotation) * q[static_cast<size_t>(i)];
    } else {
      for (int col = 0; col < 3; ++col) {  // vec(R) column-major: R q = sum_col q[col] R.col
        a.block(3 * i, 3 * col, 3, 3) = q[static_cast<size_t>(i)](col) * rh;
      }
    }
    a.block(3 * i, nr, 3, 3) = rh;
    for (int j = 0; j < nc; ++j) a(3 * i + free_axes[static_cast<size_t>(j)], nr + 3 + j) = -1.0;
    for (int k = 0; k < 3; ++k) {
      if (o.known_centre_mcs[static_cast<size_t>(k)])
        rhs(k) += *o.known_centre_mcs[static_cast<size_t>(k)];
    }
    b.segment<3>(3 * i) = rhs;
  }
  const Eigen::VectorXd x = SolveMinNorm(a, b);
  Linear out;
  out.rotation = fixed_rotation ? *fixed_rotation : Eigen::Map<const Mat3>(x.data());
  out.translation = x.segment<3>(nr);
  for (int k = 0; k < 3; ++k) {
    if (o.known_centre_mcs[static_cast<size_t>(k)])
      out.centre(k) = *o.known_centre_mcs[static_cast<size_t>(k)];
  }
  for (int j = 0; j < nc; ++j) out.centre(free_axes[static_cast<size_t>(j)]) = x(nr + 3 + j);
  out.residual = std::sqrt((a * x - b).squaredNorm() / n);
  return out;
}

// Closed form with a proper rotation: the linear solution's R projected onto SO(3), then t and
// c solved again with that R.
Linear ClosedForm(const std::vector<Pose3>& h,
                  const std::vector<Vec3>& q,
                  const HandEyeOptions& o) {
  const Linear free = SolveLinear(h, q, o, nullptr);
  const Mat3 r = NearestRotation(free.rotation);
  return SolveLinear(h, q, o, &r);
}

// A closed-form start and the side chosen for each capture's centre (0 for full clouds).
struct Start {
  Linear linear;
  std::vector<int> side;
};

// Single profiles: each capture has two centre candidates. With 15 unknowns in the closed form
// a wrong side can still fit the centres nearly as well as the right one, so the best few
// choices by closed-form residual are kept (all 2^n choices scored when few, otherwise greedy
// flips from each single flip) and the joint fit decides between them.
std::vector<Start> CandidateStarts(const std::vector<Prepared>& prepared, const HandEyeOptions& o) {
  std::vector<Pose3> h;
  for (const Prepared& p : prepared) h.push_back(p.capture->mcs_from_flange);
  const auto solve = [&](const std::vector<int>& s) {
    std::vector<Vec3> q;
    for (size_t i = 0; i < prepared.size(); ++i)
      q.push_back(prepared[i].centre_in_probe[static_cast<size_t>(s[i])]);
    return Start{ClosedForm(h, q, o), s};
  };
  std::vector<size_t> two;
  for (size_t i = 0; i < prepared.size(); ++i) {
    if (prepared[i].centre_in_probe.size() == 2) two.push_back(i);
  }
  const std::vector<int> none(prepared.size(), 0);
  std::vector<Start> all;
  if (two.size() <= static_cast<size_t>(kMaxExhaustiveProfiles)) {
    for (std::uint32_t bits = 0; bits < (1u << two.size()); ++bits) {
      std::vector<int> s = none;
      for (size_t k = 0; k < two.size(); ++k) s[two[k]] = (bits >> k) & 1u;
      all.push_back(solve(s));
    }
  } else {
    for (size_t first = 0; first <= two.size(); ++first) {
      Start best = solve(none);
      if (first < two.size()) best.side[two[first]] = 1, best = solve(best.side);
      for (bool improved = true; improved;) {
        improved = false;
        for (size_t k : two) {
          std::vector<int> s = best.side;
          s[k] ^= 1;
          Start next = solve(s);
          if (next.linear.residual < best.linear.residual) best = next, improved = true;
        }
      }
      all.push_back(best);
    }
  }
  std::sort(all.begin(), all.end(),
            [](const Start& a, const Start& b) { return a.linear.residual < b.linear.residual; });
  if (all.size() > static_cast<size_t>(kStartsRefined)) all.resize(kStartsRefined);
  return all;
}

// ------------------------------------------------------------------ joint fit

// r = |H (exp(dtheta) R0 p + t) - c| - R for one point; dtheta is a small rotation in the
// flange frame about the closed form's rotation R0 (no singularity near the solution).
struct PointOnSphere {
  PointOnSphere(const Vec3& rotated_point, const Pose3& h, double radius)
      : q(rotated_point), rh(h.linear()), th(h.translation()), radius(radius) {}
  template <class T>
  bool operator()(const T* dtheta, const T* t, const T* c, T* residual) const {
    const T p[3] = {T(q(0)), T(q(1)), T(q(2))};
    T m[3];
    ceres::AngleAxisRotatePoint(dtheta, p, m);
    for (int k = 0; k < 3; ++k) m[k] += t[k];
    T d2 = T(0);
    for (int r = 0; r < 3; ++r) {
      T w = T(th(r)) - c[r];
      for (int k = 0; k < 3; ++k) w += T(rh(r, k)) * m[k];
      d2 += w * w;
    }
    residual[0] = sqrt(d2) - T(radius);
    return true;
  }
  Vec3 q;
  Mat3 rh;
  Vec3 th;
  double radius;
};

struct Model {
  Mat3 rotation;  // R_M
  Vec3 translation;
  Vec3 centre;
  Vec3 MapToMcs(const Pose3& h, const Vec3& p) const { return h * (rotation * p + translation); }
  double Residual(const Pose3& h, const Vec3& p, double radius) const {
    return (MapToMcs(h, p) - centre).norm() - radius;
  }
};

// Inlier lists per capture: indices into Prepared::points.
using Selection = std::vector<std::vector<int>>;

Model Refine(const std::vector<Prepared>& prepared,
             const Selection& selection,
             const Model& start,
             const HandEyeOptions& o,
             double huber_mm,
             int* iterations,
             double* final_cost = nullptr) {
  double dtheta[3] = {0, 0, 0};
  double t[3] = {start.translation(0), start.translation(1), start.translation(2)};
  double c[3] = {start.centre(0), start.centre(1), start.centre(2)};
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::HuberLoss huber(huber_mm > 0 ? huber_mm : 1.0);
  ceres::LossFunction* loss = huber_mm > 0 ? &huber : nullptr;
  for (size_t i = 0; i < prepared.size(); ++i) {
    const Pose3& h = prepared[i].capture->mcs_from_flange;
    for (int j : selection[i]) {
      const Vec3 q = start.rotation * prepared[i].points.col(j);
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PointOnSphere, 1, 3, 3, 3>(
                                   new PointOnSphere(q, h, o.sphere_radius_mm)),
                               loss, dtheta, t, c);
    }
  }
  std::vector<int> fixed;
  for (int k = 0; k < 3; ++k) {
    if (o.known_centre_mcs[static_cast<size_t>(k)]) fixed.push_back(k);
  }
  if (fixed.size() == 3) {
    problem.SetParameterBlockConstant(c);
  } else if (!fixed.empty()) {
    problem.SetManifold(c, new ceres::SubsetManifold(3, fixed));
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  so.max_num_iterations = 100;
  so.function_tolerance = 1e-14;
  so.gradient_tolerance = 1e-14;
  so.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  *iterations += static_cast<int>(summary.iterations.size());
  if (final_cost) *final_cost = summary.final_cost;
  Model m;
  double rot[9];
  ceres::AngleAxisToRotationMatrix(dtheta, rot);  // column-major
  m.rotation = Eigen::Map<const Mat3>(rot) * start.rotation;
  m.translation = Vec3(t[0], t[1], t[2]);
  m.centre = Vec3(c[0], c[1], c[2]);
  return m;
}

// Jacobian row of one point's residual in (dtheta | t | c), analytically (see Refine).
Eigen::Matrix<double, 1, 9> JacobianRow(const Model& m, const Pose3& h, const Vec3& p) {
  const Vec3 a = m.rotation * p;
  const Vec3 w = h * (a + m.translation) - m.centre;
  const Vec3 u = w / w.norm();
  const Vec3 g = h.linear().transpose() * u;
  Eigen::Matrix<double, 1, 9> row;
  row << a.cross(g).transpose(), g.transpose(), -u.transpose();
  return row;
}

struct Information {
  Mat9 jtj = Mat9::Zero();
  double sum_sq = 0.0;
  int m = 0;
};

Information Accumulate(const std::vector<Prepared>& prepared,
                       const Selection& selection,
                       const Model& model,
                       double radius) {
  Information info;
  for (size_t i = 0; i < prepared.size(); ++i) {
    const Pose3& h = prepared[i].capture->mcs_from_flange;
    for (int j : selection[i]) {
      const Vec3 p = prepared[i].points.col(j);
      const auto row = JacobianRow(model, h, p);
      info.jtj.noalias() += row.transpose() * row;
      const double r = model.Residual(h, p, radius);
      info.sum_sq += r * r;
      ++info.m;
    }
  }
  return info;
}

// ------------------------------------------------------------------ observability

std::vector<std::string> Proposals(const std::vector<Vec9>& directions) {
  bool along_z = false, across = false, rotation = false;
  for (const Vec9& v : directions) {
    rotation |= v.head<3>().norm() > 0.25;
    along_z |= std::abs(v(5)) > 0.25 || std::abs(v(8)) > 0.25;
    across |= v.segment<2>(3).norm() > 0.25 || v.segment<2>(6).norm() > 0.25;
  }
  std::vector<std::string> out;
  if (across) {
    out.push_back(
        "add captures at other spindle orientations (M19 at 0, 90, 180 and 270 degrees) "
        "with the sphere in view, or give the sphere centre's X and Y");
  }
  if (along_z) {
    out.push_back(
        "give the sphere centre's Z (e.g. touched off or set with a tool setter), or add "
        "captures with the head tilted (A/B) by 15 degrees or more");
  }
  if (rotation) {
    out.push_back(
        "move the sphere across the field of view between captures (X, Y and Z by about "
        "+-10 mm) at two or more spindle orientations");
  }
  return out;
}

// Directions of the free parameters whose standard deviation exceeds `limit_mm`, in the scaled
// space; known centre coordinates are left out (their information rows are removed).
std::vector<std::pair<Vec9, double>> WeakDirections(const Information& info,
                                                    const HandEyeOptions& o,
                                                    double sigma_mm,
                                                    double limit_mm) {
  std::vector<int> free;
  for (int k = 0; k < 9; ++k) {
    if (k < 6 || !o.known_centre_mcs[static_cast<size_t>(k - 6)]) free.push_back(k);
  }
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd f(nf, nf);
  const auto scale = [&](int k) { return k < 3 ? 1.0 / o.lever_mm : 1.0; };
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b)
      f(a, b) = info.jtj(free[a], free[b]) * scale(free[a]) * scale(free[b]);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(f);
  std::vector<std::pair<Vec9, double>> weak;
  for (int k = 0; k < nf; ++k) {
    const double lambda = std::max(es.eigenvalues()(k), 0.0);
    const double std_mm = lambda > 0 ? sigma_mm / std::sqrt(lambda) : INFINITY;
    if (std_mm <= limit_mm) continue;
    Vec9 v = Vec9::Zero();
    for (int a = 0; a < nf; ++a) v(free[a]) = es.eigenvectors()(a, k);
    weak.push_back({v, std_mm});
  }
  return weak;
}

std::string FormatStd(double std_mm) {
  std::ostringstream s;
  if (std::isfinite(std_mm) && std_mm < 1e3) {
    s.precision(3);
    s << std_mm << " mm";
  } else {
    s << "not at all";
  }
  return s.str();
}

// Refuses when a combination is determined worse than `limit_mm`; warns (if asked) when worse than
// a tenth of it.
void CheckObservable(const Information& info,
                     const HandEyeOptions& o,
                     double sigma_mm,
                     double limit_mm,
                     std::vector<std::string>* warnings) {
  const auto undetermined = WeakDirections(info, o, sigma_mm, limit_mm);
  if (!undetermined.empty()) {
    std::ostringstream msg;
    msg << "the captures do not determine the calibration:";
    std::vector<Vec9> dirs;
    for (size_t k = 0; k < undetermined.size(); ++k) {
      msg << (k ? "; " : " ") << Describe(undetermined[k].first) << " trade off (determined to "
          << FormatStd(undetermined[k].second) << ")";
      dirs.push_back(undetermined[k].first);
    }
    msg << ".";
    throw HandEyeError(Kind::kUnderDetermined, msg.str(), Proposals(dirs));
  }
  if (!warnings) return;
  for (const auto& [v, s] : WeakDirections(info, o, sigma_mm, 0.1 * limit_mm)) {
    warnings->push_back("weakly determined: " + Describe(v) + " (to " + FormatStd(s) + ")");
  }
}

}  // namespace

void HandEyeOptions::Check() const {
  if (!(sphere_radius_mm > 0.0 && std::isfinite(sphere_radius_mm)))
    Bad("sphere radius must be > 0");
  for (const auto& k : known_centre_mcs) {
    if (k && !std::isfinite(*k)) Bad("a known centre coordinate is not finite");
  }
  if (!(capture_inlier_mm >= 0.0)) Bad("capture inlier threshold must be >= 0");
  if (!(trim_sigmas >= 2.0)) Bad("trimming below 2 sigma would cut good points");
  if (!(lever_mm > 0.0) || !(max_std_mm > 0.0)) Bad("lever and max std must be > 0");
}

Pose3 PoseFromXyzWpr(double x, double y, double z, double w_deg, double p_deg, double r_deg) {
  const double k = M_PI / 180.0;
  Pose3 pose = Pose3::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(r_deg * k, Vec3::UnitZ()) * Eigen::AngleAxisd(p_deg * k, Vec3::UnitY()) *
       Eigen::AngleAxisd(w_deg * k, Vec3::UnitX()))
          .toRotationMatrix();
  pose.translation() = Vec3(x, y, z);
  return pose;
}

HandEyeResult SolveSphereHandEye(const std::vector<SphereCapture>& captures,
                                 const HandEyeOptions& o) {
  o.Check();
  HandEyeResult result;
  for (const SphereCapture& c : captures) {
    if (!c.mcs_from_flange.matrix().allFinite()) Bad("capture " + c.id + ": pose is not finite");
    const Mat3 r = c.mcs_from_flange.linear();
    if ((r.transpose() * r - Mat3::Identity()).norm() > 1e-6 || r.determinant() < 0)
      Bad("capture " + c.id + ": pose's rotation is not a rotation");
  }
  std::vector<Prepared> prepared;
  for (const SphereCapture& c : captures) {
    if (auto p = Prepare(c, o, &result.warnings)) prepared.push_back(std::move(*p));
  }
  if (static_cast<int>(prepared.size()) < kMinCaptures) {
    Bad(std::to_string(prepared.size()) + " usable captures; at least " +
        std::to_string(kMinCaptures) + " (and 6 or more for a good calibration) are needed");
  }
  Selection selection;
  double sigma = 0.0;
  for (const Prepared& p : prepared) selection.push_back(p.inliers), sigma += p.fit_rms_mm;
  sigma = std::max(sigma / static_cast<double>(prepared.size()), kTrimFloorMm);
  const std::vector<Start> starts = CandidateStarts(prepared, o);
  const auto model_of = [](const Start& s) {
    return Model{s.linear.rotation, s.linear.translation, s.linear.centre};
  };
  // Pose sets that cannot work at all (a null space of the problem) are refused before any
  // iteration; the close call is made at the solution below.
  CheckObservable(Accumulate(prepared, selection, model_of(starts.front()), o.sphere_radius_mm), o,
                  sigma, kStructuralFactor * o.max_std_mm, nullptr);
  // Robust joint fit from each start; the lowest cost wins. Then plain least squares on trimmed
  // sets until the set is stable.
  Model model = model_of(starts.front());
  double best_cost = INFINITY;
  for (const Start& s : starts) {
    double cost = 0.0;
    const Model m =
        Refine(prepared, selection, model_of(s), o, 2.0 * sigma, &result.iterations, &cost);
    if (cost < best_cost) best_cost = cost, model = m;
  }
  for (int round = 0; round < kMaxTrimRounds; ++round) {
    model = Refine(prepared, selection, model, o, 0.0, &result.iterations);
    const Information info = Accumulate(prepared, selection, model, o.sphere_radius_mm);
    const double limit = std::max(o.trim_sigmas * std::sqrt(info.sum_sq / info.m), kTrimFloorMm);
    Selection next(prepared.size());
    for (size_t i = 0; i < prepared.size(); ++i) {
      const Pose3& h = prepared[i].capture->mcs_from_flange;
      // Only points its own capture's fit put on the sphere are candidates: background the
      // capture's fit rejected is not re-admitted because it happens to lie near the sphere.
      for (int j : prepared[i].inliers) {
        if (std::abs(model.Residual(h, prepared[i].points.col(j), o.sphere_radius_mm)) <= limit)
          next[i].push_back(j);
      }
    }
    if (next == selection) break;
    selection = std::move(next);
  }

  const Information info = Accumulate(prepared, selection, model, o.sphere_radius_mm);
  const int dof = info.m - 9;
  if (dof <= 0) Bad("too few points on the sphere after trimming");
  const double sigma2 = info.sum_sq / dof;
  CheckObservable(info, o, std::sqrt(sigma2), o.max_std_mm, &result.warnings);
  std::vector<int> free;
  for (int k = 0; k < 9; ++k) {
    if (k < 6 || !o.known_centre_mcs[static_cast<size_t>(k - 6)]) free.push_back(k);
  }
  Eigen::MatrixXd f(free.size(), free.size());
  for (size_t a = 0; a < free.size(); ++a) {
    for (size_t b = 0; b < free.size(); ++b) f(a, b) = info.jtj(free[a], free[b]);
  }
  const Eigen::MatrixXd cov =
      sigma2 * f.ldlt().solve(Eigen::MatrixXd::Identity(f.rows(), f.cols()));
  for (size_t a = 0; a < free.size(); ++a) {
    for (size_t b = 0; b < free.size(); ++b) result.covariance(free[a], free[b]) = cov(a, b);
  }

  result.flange_from_probe.linear() = model.rotation;
  result.flange_from_probe.translation() = model.translation;
  result.centre_mcs = model.centre;
  result.point_rms_mm = std::sqrt(info.sum_sq / info.m);
  result.points_used = info.m;
  double spread2 = 0.0;
  for (size_t i = 0; i < prepared.size(); ++i) {
    const Prepared& p = prepared[i];
    const Pose3& h = p.capture->mcs_from_flange;
    CaptureReport r;
    r.id = p.capture->id;
    r.points = static_cast<int>(p.points.cols());
    r.inliers = static_cast<int>(selection[i].size());
    double ss = 0.0;
    for (int j : selection[i]) {
      const double res = model.Residual(h, p.points.col(j), o.sphere_radius_mm);
      ss += res * res, r.max_abs_mm = std::max(r.max_abs_mm, std::abs(res));
    }
    r.rms_mm = r.inliers ? std::sqrt(ss / r.inliers) : 0.0;
    // A profile's centre: the side the solution puts it on.
    r.centre_mcs = model.MapToMcs(h, p.centre_in_probe.front());
    for (const Vec3& q : p.centre_in_probe) {
      const Vec3 m = model.MapToMcs(h, q);
      if ((m - model.centre).norm() < (r.centre_mcs - model.centre).norm()) r.centre_mcs = m;
    }
    r.fitted_radius_mm = p.fitted_radius_mm;
    const double d = (r.centre_mcs - model.centre).norm();
    spread2 += d * d, result.centre_spread_max_mm = std::max(result.centre_spread_max_mm, d);
    result.points_rejected += r.points - r.inliers;
    result.captures.push_back(r);
  }
  result.centre_spread_rms_mm = std::sqrt(spread2 / static_cast<double>(prepared.size()));
  if (!result.flange_from_probe.matrix().allFinite() || !result.covariance.allFinite() ||
      !result.centre_mcs.allFinite()) {
    throw HandEyeError(Kind::kUnderDetermined, "the fit did not converge to a finite solution");
  }
  return result;
}

}  // namespace mlp::calib
