#include "mlp/calib/hand_eye.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <cmath>
#include <iomanip>
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
  const auto n = static_cast<Eigen::Index>(h.size());
  std::vector<int> free_axes;
  for (int k = 0; k < 3; ++k) {
    if (!o.known_centre_mcs[static_cast<size_t>(k)]) free_axes.push_back(k);
  }
  const int nr = fixed_rotation ? 0 : 9, nc = static_cast<int>(free_axes.size());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(3 * n, nr + 3 + nc);
  Eigen::VectorXd b(3 * n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Mat3 rh = h[static_cast<size_t>(i)].linear();
    Vec3 rhs = -h[static_cast<size_t>(i)].translation();
    if (fixed_rotation) {
      rhs -= rh * (*fixed_rotation) * q[static_cast<size_t>(i)];
    } else {
      for (Eigen::Index col = 0; col < 3;
           ++col) {  // vec(R) column-major: R q = sum_col q[col] R.col
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
  out.residual = std::sqrt((a * x - b).squaredNorm() / static_cast<double>(n));
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
  h.reserve(prepared.size());
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

// The parameters in the order of the information matrix: rotation of M (small, flange frame) |
// t_M | c | the sensor's scale along probe X, Y, Z | its depth bias with incidence.
constexpr int kParams = 13;
constexpr int kScale = 9;
constexpr int kBias = 12;
using Vec13 = Eigen::Matrix<double, kParams, 1>;
using Mat13 = Eigen::Matrix<double, kParams, kParams>;

// Which sensor parameters are free.
struct SensorFree {
  std::array<bool, 3> scale{};
  bool bias = false;
  static SensorFree Of(const SensorModelOptions& s) {
    return {{s.scale_x, s.scale_y, s.scale_z}, s.incidence_bias};
  }
  bool Any() const { return scale[0] || scale[1] || scale[2] || bias; }
};

// 1 - cos a, a the angle between the probe's z axis and the surface normal whose z component in
// the probe frame is `n_probe_z` (unit normal).
template <class T>
T OneMinusCosIncidence(const T& n_probe_z) {
  // sqrt(z^2 + tiny): |z| with a derivative at 0 (a normal square to the axis: grazing).
  return T(1) - sqrt(n_probe_z * n_probe_z + T(1e-12));
}

// r = |H (exp(dtheta) R0 p' + t) - c| - R for one point, p' = S p + b (1 - cos a) e_z the
// sensor's reading corrected (SensorModelOptions); dtheta is a small rotation in the flange
// frame about the closed form's rotation R0 (no singularity near the solution). The normal for
// the angle is taken at S p (the bias is a small correction of a small correction).
struct PointOnSphere {
  PointOnSphere(
      const Vec3& point, const Mat3& rotation0, const Pose3& h, double radius_mm, bool bias)
      : p(point),
        r0(rotation0),
        rh(h.linear()),
        th(h.translation()),
        radius(radius_mm),
        with_bias(bias) {}
  // x = H (exp(dtheta) R0 q + t)
  template <class T>
  void Map(const T* dtheta, const T* t, const T* q, T* x) const {
    T a[3], m[3];
    for (int r = 0; r < 3; ++r) a[r] = T(r0(r, 0)) * q[0] + T(r0(r, 1)) * q[1] + T(r0(r, 2)) * q[2];
    ceres::AngleAxisRotatePoint(dtheta, a, m);
    for (int r = 0; r < 3; ++r) {
      x[r] = T(th(r));
      for (int k = 0; k < 3; ++k) x[r] += T(rh(r, k)) * (m[k] + t[k]);
    }
  }
  template <class T>
  bool operator()(
      const T* dtheta, const T* t, const T* c, const T* s, const T* b, T* residual) const {
    T q[3] = {s[0] * T(p(0)), s[1] * T(p(1)), s[2] * T(p(2))};
    T x[3];
    Map(dtheta, t, q, x);
    if (with_bias) AddBias(dtheta, t, c, b, q, x);  // the map again, with the corrected depth
    T d2 = T(0);
    for (int r = 0; r < 3; ++r) d2 += (x[r] - c[r]) * (x[r] - c[r]);
    residual[0] = sqrt(d2) - T(radius);
    return true;
  }
  // q.z += b (1 - cos a), the normal's z in the probe frame from x; x mapped again.
  template <class T>
  void AddBias(const T* dtheta, const T* t, const T* c, const T* b, T* q, T* x) const {
    T w[3], g[3], gm[3];
    for (int r = 0; r < 3; ++r) w[r] = x[r] - c[r];
    for (int k = 0; k < 3; ++k) g[k] = T(rh(0, k)) * w[0] + T(rh(1, k)) * w[1] + T(rh(2, k)) * w[2];
    const T back[3] = {-dtheta[0], -dtheta[1], -dtheta[2]};
    ceres::AngleAxisRotatePoint(back, g, gm);
    const T nz = (T(r0(0, 2)) * gm[0] + T(r0(1, 2)) * gm[1] + T(r0(2, 2)) * gm[2]) /
                 sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    q[2] += b[0] * OneMinusCosIncidence(nz);
    Map(dtheta, t, q, x);
  }
  Vec3 p;
  Mat3 r0, rh;
  Vec3 th;
  double radius;
  bool with_bias;
};

struct Model {
  Mat3 rotation;  // R_M
  Vec3 translation;
  Vec3 centre;
  Vec3 scale = Vec3::Ones();  // the sensor's, per probe axis
  double bias = 0.0;          // [mm at grazing incidence]
  // 1 - cos a at the point `p` as the sensor read it (the normal taken at S p).
  double Incidence(const Pose3& h, const Vec3& p) const {
    const Vec3 w = h * (rotation * scale.cwiseProduct(p) + translation) - centre;
    const Vec3 n_probe = rotation.transpose() * h.linear().transpose() * w.normalized();
    return OneMinusCosIncidence(n_probe.z());
  }
  // The reading corrected by the sensor model, in the probe frame.
  Vec3 Corrected(const Pose3& h, const Vec3& p) const {
    Vec3 q = scale.cwiseProduct(p);
    if (bias != 0.0) q.z() += bias * Incidence(h, p);
    return q;
  }
  Vec3 MapToMcs(const Pose3& h, const Vec3& p) const {
    return h * (rotation * Corrected(h, p) + translation);
  }
  double Residual(const Pose3& h, const Vec3& p, double radius) const {
    return (MapToMcs(h, p) - centre).norm() - radius;
  }
};

// The model at Ceres' parameter blocks (dtheta, t, c, scale, bias), M = exp(dtheta) R0.
Model ModelAt(double const* const* x, const Mat3& start_rotation) {
  Model m;
  double rot[9];
  ceres::AngleAxisToRotationMatrix(x[0], rot);  // column-major
  m.rotation = Eigen::Map<const Mat3>(rot) * start_rotation;
  m.translation = Vec3(x[1][0], x[1][1], x[1][2]);
  m.centre = Vec3(x[2][0], x[2][1], x[2][2]);
  m.scale = Vec3(x[3][0], x[3][1], x[3][2]);
  m.bias = x[4][0];
  return m;
}

// Jacobian row of one point's residual in (dtheta | t | c | scale | bias), analytically (see
// Refine; the angle of incidence held where the bias is differentiated).
Eigen::Matrix<double, 1, kParams> JacobianRow(const Model& m, const Pose3& h, const Vec3& p) {
  const Vec3 a = m.rotation * m.Corrected(h, p);
  const Vec3 w = h * (a + m.translation) - m.centre;
  const Vec3 u = w / w.norm();
  const Vec3 g = h.linear().transpose() * u;
  const Vec3 g_probe = m.rotation.transpose() * g;
  Eigen::Matrix<double, 1, kParams> row;
  row << a.cross(g).transpose(), g.transpose(), -u.transpose(), g_probe.cwiseProduct(p).transpose(),
      g_probe.z() * m.Incidence(h, p);
  return row;
}

// The left Jacobian of SO(3) at `phi`: exp(phi + e) = exp(J_l(phi) e) exp(phi) to first order
// (Barfoot, State Estimation for Robotics, 2017, eq. 7.77; series below 1e-4 rad).
Mat3 LeftJacobianSo3(const Vec3& phi) {
  const double angle = phi.norm();
  Mat3 k;
  k << 0, -phi.z(), phi.y(), phi.z(), 0, -phi.x(), -phi.y(), phi.x(), 0;
  const double a2 = angle * angle;
  const double first = angle < 1e-4 ? 0.5 - a2 / 24.0 : (1.0 - std::cos(angle)) / a2;
  const double second =
      angle < 1e-4 ? 1.0 / 6.0 - a2 / 120.0 : (angle - std::sin(angle)) / (a2 * angle);
  return Mat3::Identity() + first * k + second * k * k;
}

// The residuals of PointOnSphere for a list of points of one capture, with the Jacobian written
// out (JacobianRow, the rotation's column through the left Jacobian: the same parameters as
// PointOnSphere). For a sensor whose incidence bias is held at zero, where JacobianRow is exact;
// the bias's own column is never asked for then (its block is constant). Why not AutoDiff: on
// 13 parameters its dual numbers and one block per point were 45 % of a calibration's time
// (docs/BENCHMARKS.md); one block per capture keeps Ceres' per-block work to a few blocks.
// Ceres applies a loss to a block's whole squared norm, so the Huber loss per point is applied
// here: r' = sign(r) sqrt(rho(r^2)) with rho Ceres' HuberLoss, the same cost 1/2 sum rho(r^2)
// and gradient (not the same Gauss-Newton steps as Ceres' corrector: the same minimum).
class CaptureOnSphere : public ceres::CostFunction {
 public:
  CaptureOnSphere(geometry::Points3 points,
                  const Mat3& rotation0,
                  const Pose3& h,
                  double radius_mm,
                  double huber_mm)
      : points_(std::move(points)), r0_(rotation0), h_(h), radius_(radius_mm), huber_(huber_mm) {
    set_num_residuals(static_cast<int>(points_.cols()));
    *mutable_parameter_block_sizes() = {3, 3, 3, 3, 1};
  }
  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    const Model m = ModelAt(x, r0_);  // its bias 0: AddCapture uses this cost only then
    const Mat3 left = LeftJacobianSo3(Vec3(x[0][0], x[0][1], x[0][2]));
    for (Eigen::Index i = 0; i < points_.cols(); ++i) {
      const Vec3 p = points_.col(i);
      const double r = m.Residual(h_, p, radius_);
      const bool beyond = huber_ > 0.0 && std::abs(r) > huber_;
      // Beyond the Huber threshold d: rho = 2 d |r| - d^2, dr'/dr = d / |r'|.
      residuals[i] =
          beyond ? std::copysign(std::sqrt(2.0 * huber_ * std::abs(r) - huber_ * huber_), r) : r;
      if (jacobians == nullptr) continue;
      const Eigen::Matrix<double, 1, kParams> row =
          JacobianRow(m, h_, p) * (beyond ? huber_ / std::abs(residuals[i]) : 1.0);
      const Eigen::RowVector3d rotation_row = row.head<3>() * left;
      Put(jacobians[0], i, rotation_row.data(), 3);
      Put(jacobians[1], i, row.data() + 3, 3);
      Put(jacobians[2], i, row.data() + 6, 3);
      Put(jacobians[3], i, row.data() + kScale, 3);
      Put(jacobians[4], i, row.data() + kBias, 1);
    }
    return true;
  }

 private:
  // Row i of a row-major Jacobian block of `size` columns (none when Ceres does not ask).
  static void Put(double* block, Eigen::Index i, const double* row, int size) {
    if (block == nullptr) return;
    for (int k = 0; k < size; ++k) block[i * size + k] = row[k];
  }
  geometry::Points3 points_;
  Mat3 r0_;
  Pose3 h_;
  double radius_;
  double huber_;  // [mm], 0: plain least squares
};

// Inlier lists per capture: indices into Prepared::points.
using Selection = std::vector<std::vector<int>>;

// Holds the parameters of `block` listed in `fixed` (all of them: the block is constant).
void HoldFixed(ceres::Problem* problem, double* block, int size, const std::vector<int>& fixed) {
  if (static_cast<int>(fixed.size()) == size) {
    problem->SetParameterBlockConstant(block);
  } else if (!fixed.empty()) {
    problem->SetManifold(block, new ceres::SubsetManifold(size, fixed));
  }
}

// The model as Ceres' parameter blocks.
struct Blocks {
  double dtheta[3] = {0, 0, 0};
  double t[3], c[3], s[3], b[1];
  explicit Blocks(const Model& m) {
    for (int k = 0; k < 3; ++k) t[k] = m.translation(k), c[k] = m.centre(k), s[k] = m.scale(k);
    b[0] = m.bias;
  }
  Model ToModel(const Mat3& start_rotation) const {
    const double* const blocks[] = {dtheta, t, c, s, b};
    return ModelAt(blocks, start_rotation);
  }
};

// One capture's points as residual blocks of `problem`, under a Huber loss when `loss` is given
// (its threshold `huber_mm`). With the bias held at zero, one block for the capture with the
// Jacobian written out; with the bias free, one automatically differentiated block per point
// (the incidence angle's own derivative).
void AddCapture(const Prepared& capture,
                const std::vector<int>& selected,
                const Model& start,
                double radius_mm,
                bool bias_free,
                double huber_mm,
                ceres::LossFunction* loss,
                Blocks* x,
                ceres::Problem* problem) {
  if (selected.empty()) return;
  const Pose3& h = capture.capture->mcs_from_flange;
  if (bias_free || start.bias != 0.0) {
    for (int j : selected) {
      problem->AddResidualBlock(
          new ceres::AutoDiffCostFunction<PointOnSphere, 1, 3, 3, 3, 3, 1>(
              new PointOnSphere(capture.points.col(j), start.rotation, h, radius_mm, bias_free)),
          loss, x->dtheta, x->t, x->c, x->s, x->b);
    }
    return;
  }
  geometry::Points3 points(3, static_cast<Eigen::Index>(selected.size()));
  for (size_t k = 0; k < selected.size(); ++k)
    points.col(static_cast<Eigen::Index>(k)) = capture.points.col(selected[k]);
  problem->AddResidualBlock(new CaptureOnSphere(std::move(points), start.rotation, h, radius_mm,
                                                loss != nullptr ? huber_mm : 0.0),
                            nullptr, x->dtheta, x->t, x->c, x->s, x->b);
}

Model Refine(const std::vector<Prepared>& prepared,
             const Selection& selection,
             const Model& start,
             const HandEyeOptions& o,
             const SensorFree& free,
             double huber_mm,
             int* iterations,
             double* final_cost = nullptr) {
  Blocks x(start);
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  ceres::HuberLoss huber(huber_mm > 0 ? huber_mm : 1.0);
  ceres::LossFunction* loss = huber_mm > 0 ? &huber : nullptr;
  for (size_t i = 0; i < prepared.size(); ++i) {
    AddCapture(prepared[i], selection[i], start, o.sphere_radius_mm, free.bias, huber_mm, loss, &x,
               &problem);
  }
  if (problem.NumResidualBlocks() == 0) return start;
  std::vector<int> fixed_centre, fixed_scale;
  for (int k = 0; k < 3; ++k) {
    if (o.known_centre_mcs[static_cast<size_t>(k)]) fixed_centre.push_back(k);
    if (!free.scale[static_cast<size_t>(k)]) fixed_scale.push_back(k);
  }
  HoldFixed(&problem, x.c, 3, fixed_centre);
  HoldFixed(&problem, x.s, 3, fixed_scale);
  if (!free.bias) problem.SetParameterBlockConstant(x.b);
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
  return x.ToModel(start.rotation);
}

struct Information {
  Mat13 jtj = Mat13::Zero();
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

// The parameters the data must determine: M, the centre coordinates not given, the free sensor
// parameters.
std::vector<int> FreeParameters(const HandEyeOptions& o, const SensorFree& sensor) {
  std::vector<int> free;
  for (int k = 0; k < kParams; ++k) {
    const bool centre_given = k >= 6 && k < 9 && o.known_centre_mcs[static_cast<size_t>(k - 6)];
    const bool scale_held =
        k >= kScale && k < kBias && !sensor.scale[static_cast<size_t>(k - kScale)];
    const bool bias_held = k == kBias && !sensor.bias;
    if (!centre_given && !scale_held && !bias_held) free.push_back(k);
  }
  return free;
}

// sigma^2 (J^T J)^-1 over the free parameters, placed in the full layout (zeros elsewhere).
Mat13 Covariance(const Information& info, const std::vector<int>& free, double sigma2) {
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd f(nf, nf);
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b) f(a, b) = info.jtj(free[a], free[b]);
  }
  const Eigen::MatrixXd cov = sigma2 * f.ldlt().solve(Eigen::MatrixXd::Identity(nf, nf));
  Mat13 out = Mat13::Zero();
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b) out(free[a], free[b]) = cov(a, b);
  }
  return out;
}

// ------------------------------------------------------------------ observability

std::vector<std::string> Proposals(const std::vector<Vec13>& directions) {
  bool along_z = false, across = false, rotation = false, sensor = false;
  for (const Vec13& v : directions) {
    rotation |= v.head<3>().norm() > 0.25;
    along_z |= std::abs(v(5)) > 0.25 || std::abs(v(8)) > 0.25;
    across |= v.segment<2>(3).norm() > 0.25 || v.segment<2>(6).norm() > 0.25;
    sensor |= v.tail<4>().norm() > 0.25;
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
  if (sensor) {
    out.push_back(
        "capture the sphere at several stand-off distances (a scale grows with depth) and "
        "off-centre in the field of view (the angle of incidence changes across the sphere), "
        "or estimate fewer sensor parameters");
  }
  return out;
}

// Directions of the free parameters whose standard deviation exceeds `limit_mm`, in the scaled
// space (rotations and scales times the lever); fixed parameters are left out.
std::vector<std::pair<Vec13, double>> WeakDirections(const Information& info,
                                                     const HandEyeOptions& o,
                                                     const SensorFree& sensor,
                                                     double sigma_mm,
                                                     double limit_mm) {
  const std::vector<int> free = FreeParameters(o, sensor);
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd f(nf, nf);
  const auto scale = [&](int k) {
    return k < 3 || (k >= kScale && k < kBias) ? 1.0 / o.lever_mm : 1.0;
  };
  for (int a = 0; a < nf; ++a) {
    for (int b = 0; b < nf; ++b)
      f(a, b) = info.jtj(free[a], free[b]) * scale(free[a]) * scale(free[b]);
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(f);
  std::vector<std::pair<Vec13, double>> weak;
  for (int k = 0; k < nf; ++k) {
    const double lambda = std::max(es.eigenvalues()(k), 0.0);
    const double std_mm = lambda > 0 ? sigma_mm / std::sqrt(lambda) : INFINITY;
    if (std_mm <= limit_mm) continue;
    Vec13 v = Vec13::Zero();
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
                     const SensorFree& sensor,
                     double sigma_mm,
                     double limit_mm,
                     std::vector<std::string>* warnings) {
  const auto undetermined = WeakDirections(info, o, sensor, sigma_mm, limit_mm);
  if (!undetermined.empty()) {
    std::ostringstream msg;
    msg << "the captures do not determine the calibration:";
    std::vector<Vec13> dirs;
    for (size_t k = 0; k < undetermined.size(); ++k) {
      msg << (k ? "; " : " ") << Describe(undetermined[k].first) << " trade off (determined to "
          << FormatStd(undetermined[k].second) << ")";
      dirs.push_back(undetermined[k].first);
    }
    msg << ".";
    throw HandEyeError(Kind::kUnderDetermined, msg.str(), Proposals(dirs));
  }
  if (!warnings) return;
  for (const auto& [v, s] : WeakDirections(info, o, sensor, sigma_mm, 0.1 * limit_mm)) {
    warnings->push_back("weakly determined: " + Describe(v) + " (to " + FormatStd(s) + ")");
  }
}

// Whether the poses cannot tell the incidence bias from the rest (a scale, M).
bool BiasAmbiguous(const Information& info,
                   const HandEyeOptions& o,
                   const SensorFree& sensor,
                   double sigma_mm) {
  if (!sensor.bias) return false;
  for (const auto& [v, std_mm] : WeakDirections(info, o, sensor, sigma_mm, o.max_std_mm)) {
    if (std::abs(v(kBias)) > 0.25) return true;
  }
  return false;
}

// ------------------------------------------------------------------ per-capture centres

// Where a capture's points, mapped by `m`, put the sphere (radius held), on the side of `near`.
// A profile is a circle: its centre lies sqrt(R^2 - rho^2) off the circle's plane on either side,
// and the side nearer `near` is taken (a fit of the sphere itself could slide across the plane
// where the cut is near the equator). A cloud: Gauss-Newton on the sphere from `near`.
Vec3 CaptureCentre(const Model& m,
                   const Prepared& p,
                   const std::vector<int>& points,
                   double radius,
                   const Vec3& near) {
  const Pose3& h = p.capture->mcs_from_flange;
  geometry::Points3 x(3, static_cast<Eigen::Index>(points.size()));
  for (size_t k = 0; k < points.size(); ++k)
    x.col(static_cast<Eigen::Index>(k)) = m.MapToMcs(h, p.points.col(points[k]));
  if (x.cols() < 4) return near;
  if (p.capture->single_profile) {
    try {
      const geometry::Circle3 circle = geometry::FitCircle3(x).shape;
      const double off = std::sqrt(std::max(0.0, radius * radius - circle.radius * circle.radius));
      const Vec3 a = circle.center + off * circle.normal, b = circle.center - off * circle.normal;
      return (a - near).norm() <= (b - near).norm() ? a : b;
    } catch (const geometry::GeometryError&) {
      return near;
    }
  }
  return geometry::SphereCentreWithRadius(x, radius, near);
}

// ------------------------------------------------------------------ the solution's steps

struct Solved {
  Model model;
  Selection selection;
  SensorFree sensor;
};

// Plain least squares on trimmed sets (3 RMS) until the set is stable.
void TrimAndRefine(const std::vector<Prepared>& prepared,
                   const HandEyeOptions& o,
                   Solved* s,
                   int* iterations) {
  for (int round = 0; round < kMaxTrimRounds; ++round) {
    s->model = Refine(prepared, s->selection, s->model, o, s->sensor, 0.0, iterations);
    const Information info = Accumulate(prepared, s->selection, s->model, o.sphere_radius_mm);
    const double limit = std::max(o.trim_sigmas * std::sqrt(info.sum_sq / info.m), kTrimFloorMm);
    Selection next(prepared.size());
    for (size_t i = 0; i < prepared.size(); ++i) {
      const Pose3& h = prepared[i].capture->mcs_from_flange;
      // Only points its own capture's fit put on the sphere are candidates: background the
      // capture's fit rejected is not re-admitted because it happens to lie near the sphere.
      for (int j : prepared[i].inliers) {
        if (std::abs(s->model.Residual(h, prepared[i].points.col(j), o.sphere_radius_mm)) <= limit)
          next[i].push_back(j);
      }
    }
    if (next == s->selection) break;
    s->selection = std::move(next);
  }
}

// A finding when a scale is further from 1 than the limit and than 3 sigma.
std::optional<std::string> ScaleFinding(int axis, double scale, double std, double limit) {
  const double off = scale - 1.0;
  if (std::abs(off) < limit || std::abs(off) < 3.0 * std) return std::nullopt;
  const char* const names[3] = {"lateral (x)", "lateral (y)", "depth (z)"};
  std::ostringstream m;
  m << std::fixed << std::setprecision(2) << "the probe's " << names[axis] << " scale is "
    << 100.0 * std::abs(off) << " % off its calibration (its readings fit the sphere x"
    << std::setprecision(4) << scale << " +- " << std << "): recalibrate the camera/projector";
  return m.str();
}

// The sensor's parameters with their uncertainty and what they say to a person.
SensorEstimate EstimateSensor(const Solved& s, const Mat13& cov, const HandEyeOptions& o) {
  SensorEstimate e;
  e.estimated = s.sensor.Any();
  e.scale = s.model.scale;
  for (int k = 0; k < 3; ++k) e.scale_std(k) = std::sqrt(cov(kScale + k, kScale + k));
  e.incidence_bias_mm = s.model.bias;
  e.incidence_bias_std_mm = std::sqrt(cov(kBias, kBias));
  if (s.sensor.scale[2] && s.sensor.bias) {
    e.scale_bias_correlation =
        cov(kScale + 2, kBias) / std::sqrt(cov(kScale + 2, kScale + 2) * cov(kBias, kBias));
  }
  for (int k = 0; k < 3; ++k) {
    if (!s.sensor.scale[static_cast<size_t>(k)]) continue;
    if (auto f = ScaleFinding(k, e.scale(k), e.scale_std(k), o.sensor.finding_scale))
      e.findings.push_back(*f);
  }
  if (s.sensor.bias && std::abs(e.incidence_bias_mm) >= o.sensor.finding_bias_mm &&
      std::abs(e.incidence_bias_mm) >= 3.0 * e.incidence_bias_std_mm) {
    std::ostringstream m;
    m << std::fixed << std::setprecision(3)
      << "the probe's depth reading depends on the angle of incidence: " << e.incidence_bias_mm
      << " +- " << e.incidence_bias_std_mm
      << " mm at grazing light (a shiny surface; measure a matt one, or correct for it)";
    e.findings.push_back(m.str());
  }
  return e;
}

// Each capture predicted by the solution of all the others (same sensor model, same point sets).
LeaveOneOut ValidateLeaveOneOut(const std::vector<Prepared>& prepared,
                                const Solved& s,
                                const HandEyeOptions& o,
                                int* iterations) {
  LeaveOneOut out;
  if (static_cast<int>(prepared.size()) <= kMinCaptures) return out;
  double sum_sq = 0.0, centre_sq = 0.0;
  int points = 0;
  for (size_t i = 0; i < prepared.size(); ++i) {
    Selection others = s.selection;
    others[i].clear();
    const Model m = Refine(prepared, others, s.model, o, s.sensor, 0.0, iterations);
    HeldOutCapture held{prepared[i].capture->id, 0.0, 0.0};
    const Pose3& h = prepared[i].capture->mcs_from_flange;
    double ss = 0.0;
    for (int j : s.selection[i]) {
      const double r = m.Residual(h, prepared[i].points.col(j), o.sphere_radius_mm);
      ss += r * r;
    }
    const int n = static_cast<int>(s.selection[i].size());
    held.rms_mm = n ? std::sqrt(ss / n) : 0.0;
    held.centre_error_mm =
        (CaptureCentre(m, prepared[i], s.selection[i], o.sphere_radius_mm, m.centre) - m.centre)
            .norm();
    sum_sq += ss, points += n, centre_sq += held.centre_error_mm * held.centre_error_mm;
    out.captures.push_back(held);
  }
  out.rms_mm = points ? std::sqrt(sum_sq / points) : 0.0;
  out.centre_error_rms_mm = std::sqrt(centre_sq / static_cast<double>(out.captures.size()));
  return out;
}

// The per-capture report and the centres' spread about their mean.
void ReportCaptures(const std::vector<Prepared>& prepared,
                    const Solved& s,
                    const HandEyeOptions& o,
                    HandEyeResult* result) {
  Vec3 mean = Vec3::Zero();
  for (size_t i = 0; i < prepared.size(); ++i) {
    const Prepared& p = prepared[i];
    const Pose3& h = p.capture->mcs_from_flange;
    CaptureReport r;
    r.id = p.capture->id;
    r.points = static_cast<int>(p.points.cols());
    r.on_sphere = static_cast<int>(p.inliers.size());
    r.inliers = static_cast<int>(s.selection[i].size());
    double ss = 0.0;
    for (int j : s.selection[i]) {
      const double res = s.model.Residual(h, p.points.col(j), o.sphere_radius_mm);
      ss += res * res, r.max_abs_mm = std::max(r.max_abs_mm, std::abs(res));
    }
    r.rms_mm = r.inliers ? std::sqrt(ss / r.inliers) : 0.0;
    r.centre_mcs = CaptureCentre(s.model, p, s.selection[i], o.sphere_radius_mm, s.model.centre);
    r.fitted_radius_mm = p.fitted_radius_mm;
    mean += r.centre_mcs / static_cast<double>(prepared.size());
    result->points_rejected += r.points - r.inliers;
    result->captures.push_back(r);
  }
  double spread2 = 0.0;
  for (const CaptureReport& r : result->captures) {
    const double d = (r.centre_mcs - mean).norm();
    spread2 += d * d, result->centre_spread_max_mm = std::max(result->centre_spread_max_mm, d);
  }
  result->centre_spread_rms_mm = std::sqrt(spread2 / static_cast<double>(prepared.size()));
  result->centre_mean_offset_mm = (mean - s.model.centre).norm();
}

// What the points' noise alone would spread a capture's centre by [mm^2]: sigma^2 trace of the
// inverse of the centre's normal matrix (the unit normals at its points, radius held), infinite
// for a single profile (its centre lies on a circle's axis, loosely) or too few points.
double CentreNoiseVar(const Model& m,
                      const Prepared& p,
                      const std::vector<int>& points,
                      double sigma_mm) {
  if (p.capture->single_profile || points.size() < 4) return HUGE_VAL;
  Mat3 info = Mat3::Zero();
  for (int j : points) {
    const Vec3 d = m.MapToMcs(p.capture->mcs_from_flange, p.points.col(j)) - m.centre;
    if (d.norm() > 0) info += d.normalized() * d.normalized().transpose();
  }
  const Eigen::FullPivLU<Mat3> lu(info);
  if (!lu.isInvertible()) return HUGE_VAL;
  return sigma_mm * sigma_mm * lu.inverse().trace();
}

// The captures' centres disagree far beyond what their points' noise explains: a pose H is
// wrong (a machine's geometry; on a five-axis machine its kinematics, docs/KINEMATICS.md: pins
// 30-40 um off put M 56 um off with a 24 um spread and nothing else said), a capture was taken
// moving, or the sphere moved. Said as a warning with both figures. Caps only; the floor keeps
// a probe's own few-micrometre form errors from raising it.
void WarnIfCentresDisagree(const std::vector<Prepared>& prepared,
                           const Solved& s,
                           HandEyeResult* result) {
  constexpr double kBeyondNoise = 5.0, kFloorMm = 0.005;
  double expected2 = 0.0;
  int caps = 0;
  for (size_t i = 0; i < prepared.size(); ++i) {
    const double v = CentreNoiseVar(s.model, prepared[i], s.selection[i], result->point_rms_mm);
    if (std::isfinite(v)) expected2 += v, ++caps;
  }
  if (caps < 2 || !(result->centre_spread_rms_mm > kFloorMm)) return;
  const double expected = std::sqrt(expected2 / caps);
  if (result->centre_spread_rms_mm <= kBeyondNoise * expected) return;
  std::ostringstream w;
  w.setf(std::ios::fixed);
  w.precision(1);
  w << "the captures' sphere centres spread " << result->centre_spread_rms_mm * 1e3
    << " um RMS where their points' noise explains " << expected * 1e3
    << " um: a pose is wrong (the machine's geometry or, on a five-axis machine, its "
       "kinematics: mlp kinematics check), a capture was taken moving, or the sphere moved; M "
       "takes that error";
  result->warnings.push_back(w.str());
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
  const double k = 1.0 / base::kDegPerRad;
  Pose3 pose = Pose3::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(r_deg * k, Vec3::UnitZ()) * Eigen::AngleAxisd(p_deg * k, Vec3::UnitY()) *
       Eigen::AngleAxisd(w_deg * k, Vec3::UnitX()))
          .toRotationMatrix();
  pose.translation() = Vec3(x, y, z);
  return pose;
}

namespace {

void CheckPoses(const std::vector<SphereCapture>& captures) {
  for (const SphereCapture& c : captures) {
    if (!c.mcs_from_flange.matrix().allFinite()) Bad("capture " + c.id + ": pose is not finite");
    const Mat3 r = c.mcs_from_flange.linear();
    if ((r.transpose() * r - Mat3::Identity()).norm() > 1e-6 || r.determinant() < 0)
      Bad("capture " + c.id + ": pose's rotation is not a rotation");
  }
}

// The robust joint fit (rigid: the sensor as calibrated) from every closed-form start; the
// lowest cost wins.
Model BestStart(const std::vector<Prepared>& prepared,
                const Selection& selection,
                const HandEyeOptions& o,
                double sigma,
                int* iterations) {
  const std::vector<Start> starts = CandidateStarts(prepared, o);
  const auto model_of = [](const Start& s) {
    return Model{s.linear.rotation, s.linear.translation, s.linear.centre};
  };
  // Pose sets that cannot work at all (a null space of the problem, the sensor parameters asked
  // for included) are refused before any iteration; the close call is made at the solution.
  CheckObservable(Accumulate(prepared, selection, model_of(starts.front()), o.sphere_radius_mm), o,
                  SensorFree::Of(o.sensor), sigma, kStructuralFactor * o.max_std_mm, nullptr);
  Model model = model_of(starts.front());
  double best_cost = INFINITY;
  for (const Start& s : starts) {
    double cost = 0.0;
    const Model m =
        Refine(prepared, selection, model_of(s), o, SensorFree{}, 2.0 * sigma, iterations, &cost);
    if (cost < best_cost) best_cost = cost, model = m;
  }
  return model;
}

// The joint fit with the sensor model asked for; when the poses cannot tell the incidence bias
// from the rest, it is dropped (and said) rather than the whole calibration refused.
Solved SolveJoint(const std::vector<Prepared>& prepared,
                  Selection selection,
                  const Model& rigid,
                  const HandEyeOptions& o,
                  std::vector<std::string>* warnings,
                  int* iterations) {
  Solved s{rigid, std::move(selection), SensorFree::Of(o.sensor)};
  TrimAndRefine(prepared, o, &s, iterations);
  const Information info = Accumulate(prepared, s.selection, s.model, o.sphere_radius_mm);
  const double sigma_mm = std::sqrt(info.sum_sq / std::max(1, info.m - kParams));
  if (BiasAmbiguous(info, o, s.sensor, sigma_mm)) {
    warnings->push_back(
        "ambiguous: these poses cannot tell an incidence-angle bias from the sensor's scale and "
        "the mounting; the bias is not estimated");
    s.sensor.bias = false;
    s.model.bias = 0.0;
    TrimAndRefine(prepared, o, &s, iterations);
  }
  return s;
}

}  // namespace

HandEyeResult SolveSphereHandEye(const std::vector<SphereCapture>& captures,
                                 const HandEyeOptions& o) {
  o.Check();
  CheckPoses(captures);
  HandEyeResult result;
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
  const Model rigid = BestStart(prepared, selection, o, sigma, &result.iterations);
  const Solved s = SolveJoint(prepared, selection, rigid, o, &result.warnings, &result.iterations);

  const Information info = Accumulate(prepared, s.selection, s.model, o.sphere_radius_mm);
  const std::vector<int> free = FreeParameters(o, s.sensor);
  const int dof = info.m - static_cast<int>(free.size());
  if (dof <= 0) Bad("too few points on the sphere after trimming");
  const double sigma2 = info.sum_sq / dof;
  CheckObservable(info, o, s.sensor, std::sqrt(sigma2), o.max_std_mm, &result.warnings);
  const Mat13 cov = Covariance(info, free, sigma2);
  result.covariance = cov.topLeftCorner<9, 9>();
  result.sensor = EstimateSensor(s, cov, o);
  result.flange_from_probe.linear() = s.model.rotation;
  result.flange_from_probe.translation() = s.model.translation;
  result.centre_mcs = s.model.centre;
  result.point_rms_mm = std::sqrt(info.sum_sq / info.m);
  result.points_used = info.m;
  ReportCaptures(prepared, s, o, &result);
  WarnIfCentresDisagree(prepared, s, &result);
  if (o.leave_one_out)
    result.leave_one_out = ValidateLeaveOneOut(prepared, s, o, &result.iterations);
  if (!result.flange_from_probe.matrix().allFinite() || !result.covariance.allFinite() ||
      !result.centre_mcs.allFinite() || !result.sensor.scale.allFinite() ||
      !std::isfinite(result.sensor.incidence_bias_mm)) {
    throw HandEyeError(Kind::kUnderDetermined, "the fit did not converge to a finite solution");
  }
  return result;
}

}  // namespace mlp::calib
