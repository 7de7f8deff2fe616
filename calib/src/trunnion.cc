#include "mlp/calib/trunnion.h"

#include "mlp/base/units.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <Eigen/Dense>
#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace mlp::calib {
namespace {

using base::kPi;
constexpr double kDeg = 1.0 / base::kDegPerRad;  // radians in a degree
constexpr int kParams = 11;  // A: 2 position + 2 direction; C: the same; the sphere: 3
using Params = std::array<double, kParams>;

// Two unit vectors square to `u` and to each other: the directions a line may move and turn in.
void Square(const Vec3& u, Vec3* e1, Vec3* e2) {
  const Vec3 seed = std::abs(u.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  *e1 = (seed - seed.dot(u) * u).normalized();
  *e2 = u.cross(*e1);
}

// The lines as parameters about the nominal: each line's point moves square to its nominal
// direction (a point along the line is no parameter: the gauge) and its direction tilts by two
// small components; the sphere's table position is the last three.
class Parameterisation {
 public:
  explicit Parameterisation(const TrunnionAxes& nominal) : nominal_(nominal) {
    Square(nominal.a.direction, &a1_, &a2_);
    Square(nominal.c.direction, &c1_, &c2_);
  }

  template <typename T>
  void Lines(const T* p,
             Eigen::Matrix<T, 3, 1>* oa,
             Eigen::Matrix<T, 3, 1>* ua,
             Eigen::Matrix<T, 3, 1>* oc,
             Eigen::Matrix<T, 3, 1>* uc) const {
    *oa = nominal_.a.point.cast<T>() + p[0] * a1_.cast<T>() + p[1] * a2_.cast<T>();
    *ua =
        (nominal_.a.direction.cast<T>() + p[2] * a1_.cast<T>() + p[3] * a2_.cast<T>()).normalized();
    *oc = nominal_.c.point.cast<T>() + p[4] * c1_.cast<T>() + p[5] * c2_.cast<T>();
    *uc =
        (nominal_.c.direction.cast<T>() + p[6] * c1_.cast<T>() + p[7] * c2_.cast<T>()).normalized();
  }

  TrunnionAxes Axes(const Params& p) const {
    Vec3 oa, ua, oc, uc;
    Lines(p.data(), &oa, &ua, &oc, &uc);
    return {{oa, ua}, {oc, uc}};
  }

 private:
  TrunnionAxes nominal_;
  Vec3 a1_, a2_, c1_, c2_;
};

// x turned by t [rad] about the line (o, u), right-handed.
template <typename T>
Eigen::Matrix<T, 3, 1> Turned(const Eigen::Matrix<T, 3, 1>& x,
                              const Eigen::Matrix<T, 3, 1>& o,
                              const Eigen::Matrix<T, 3, 1>& u,
                              T t) {
  const Eigen::Matrix<T, 3, 1> aa = u * t, d = x - o;
  Eigen::Matrix<T, 3, 1> out;
  ceres::AngleAxisRotatePoint(aa.data(), d.data(), out.data());
  return out + o;
}

// One observation's residual: the model's centre less the measured one, in sigmas.
struct CentreResidual {
  const Parameterisation* param;
  TrunnionObservation obs;
  double sigma_mm;

  template <typename T>
  bool operator()(const T* p, T* r) const {
    Eigen::Matrix<T, 3, 1> oa, ua, oc, uc;
    param->Lines(p, &oa, &ua, &oc, &uc);
    const Eigen::Matrix<T, 3, 1> s(p[8], p[9], p[10]);
    const Eigen::Matrix<T, 3, 1> m =
        Turned(Turned(s, oc, uc, T(obs.c_deg * kDeg)), oa, ua, T(obs.a_deg * kDeg));
    for (int k = 0; k < 3; ++k) r[k] = (m[k] - obs.centre_machine_mm[k]) / sigma_mm;
    return true;
  }
};

// The plan must make each line a circle's axis: three C positions at one A, three A positions.
void CheckPlan(const std::vector<TrunnionObservation>& obs) {
  std::set<long> a_values;
  std::map<long, std::set<long>> c_at_a;
  for (const TrunnionObservation& o : obs) {
    if (!o.centre_machine_mm.allFinite() || !std::isfinite(o.a_deg) || !std::isfinite(o.c_deg))
      throw TrunnionError("trunnion: an observation is not a finite number");
    const long a = std::lround(o.a_deg * 1000), c = std::lround(std::fmod(o.c_deg, 360.0) * 1000);
    a_values.insert(a);
    c_at_a[a].insert(c);
  }
  size_t most_c = 0;
  for (const auto& [a, cs] : c_at_a) most_c = std::max(most_c, cs.size());
  if (a_values.size() < 3 || most_c < 3)
    throw TrunnionError("trunnion: the plan has " + std::to_string(a_values.size()) +
                        " A positions and at most " + std::to_string(most_c) +
                        " C positions at one A; each line needs three (a circle's axis)");
}

// The points where two lines come closest (on a, on c).
void Closest(const AxisLine& a, const AxisLine& c, Vec3* on_a, Vec3* on_c) {
  const Vec3 w = a.point - c.point;
  const double b = a.direction.dot(c.direction), d = a.direction.dot(w), e = c.direction.dot(w);
  const double den = 1.0 - b * b;
  const double s = den > 1e-12 ? (b * e - d) / den : 0.0;
  const double t = den > 1e-12 ? (e - b * d) / den : e;
  *on_a = a.point + s * a.direction;
  *on_c = c.point + t * c.direction;
}

// The reported quantities of a parameter vector: c_x, c_y, a_y, a_z [mm], the four direction
// angles and A-C squareness [deg].
Eigen::Matrix<double, 9, 1> Derived(const Parameterisation& param, const Params& p) {
  const TrunnionAxes ax = param.Axes(p);
  Vec3 on_a, on_c;
  Closest(ax.a, ax.c, &on_a, &on_c);
  const Vec3& ua = ax.a.direction;
  const Vec3& uc = ax.c.direction;
  Eigen::Matrix<double, 9, 1> g;
  g << on_c.x(), on_c.y(), on_a.y(), on_a.z(), std::atan2(ua.y(), ua.x()) / kDeg,
      std::atan2(-ua.z(), ua.x()) / kDeg, std::atan2(-uc.y(), uc.z()) / kDeg,
      std::atan2(uc.x(), uc.z()) / kDeg, -std::asin(std::clamp(ua.dot(uc), -1.0, 1.0)) / kDeg;
  return g;
}

// Standard uncertainties of Derived from the parameters' covariance (central differences).
Eigen::Matrix<double, 9, 1> DerivedU(const Parameterisation& param,
                                     const Params& p,
                                     const Eigen::MatrixXd& cov) {
  Eigen::Matrix<double, 9, kParams> g;
  for (int k = 0; k < kParams; ++k) {
    constexpr double kStep = 1e-7;
    Params hi = p, lo = p;
    hi[static_cast<size_t>(k)] += kStep, lo[static_cast<size_t>(k)] -= kStep;
    g.col(k) = (Derived(param, hi) - Derived(param, lo)) / (2 * kStep);
  }
  const Eigen::Matrix<double, 9, 9> c = g * cov * g.transpose();
  return c.diagonal().cwiseMax(0.0).cwiseSqrt();
}

}  // namespace

void TrunnionFitOptions::Check() const {
  if (!(centre_sigma_mm > 0) || !(max_residual_rms_mm > 0))
    throw TrunnionError("trunnion: the centres' sigma and the residual limit must be > 0");
}

TrunnionAxes AxesOf(const TrtPins& p) {
  TrunnionAxes axes;
  axes.c = {Vec3(p.x_rot_point, p.y_rot_point, 0.0), Vec3::UnitZ()};
  axes.a = {
      Vec3(p.x_rot_point, p.y_rot_point + p.y_offset, p.z_rot_point + p.z_offset + p.tool_offset),
      Vec3::UnitX()};
  return axes;
}

Pose3 MachineFromTable(const TrunnionAxes& axes, double a_deg, double c_deg) {
  const auto about = [](const AxisLine& l, double deg) {
    Pose3 t = Pose3::Identity();
    t.linear() = Eigen::AngleAxisd(deg * kDeg, l.direction.normalized()).toRotationMatrix();
    t.translation() = l.point - t.linear() * l.point;
    return t;
  };
  return about(axes.a, a_deg) * about(axes.c, c_deg);
}

Pose3 TableFromFlange(const TrunnionAxes& axes,
                      const Vec3& gauge_point_machine_mm,
                      double a_deg,
                      double c_deg,
                      double spindle_deg) {
  Pose3 machine = Pose3::Identity();
  machine.translation() = gauge_point_machine_mm;
  machine.linear() =
      (Eigen::AngleAxisd(spindle_deg * kDeg, Vec3::UnitZ()) * Eigen::AngleAxisd(kPi, Vec3::UnitX()))
          .toRotationMatrix();
  return MachineFromTable(axes, a_deg, c_deg).inverse() * machine;
}

namespace {

// The least-squares solution from the nominal lines: the parameters, the whitened residuals at
// the solution, its Jacobian's normal matrix and the solver's iterations.
struct Solution {
  Params p{};
  std::vector<double> residuals;
  Eigen::MatrixXd jtj;
  int iterations = 0;
};

Solution Solve(const std::vector<TrunnionObservation>& observations,
               const TrunnionAxes& nominal,
               const Parameterisation& param,
               double sigma_mm) {
  Solution out;
  // The sphere's start: the first observation carried back through the nominal axes.
  const TrunnionObservation& first = observations.front();
  const Vec3 s0 =
      MachineFromTable(nominal, first.a_deg, first.c_deg).inverse() * first.centre_machine_mm;
  out.p[8] = s0.x(), out.p[9] = s0.y(), out.p[10] = s0.z();
  ceres::Problem problem;
  for (const TrunnionObservation& o : observations) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CentreResidual, 3, kParams>(
                                 new CentreResidual{&param, o, sigma_mm}),
                             nullptr, out.p.data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.function_tolerance = 1e-14, so.parameter_tolerance = 1e-14, so.gradient_tolerance = 1e-16;
  so.max_num_iterations = 200;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  out.iterations = static_cast<int>(summary.iterations.size());
  ceres::CRSMatrix crs;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, &out.residuals, nullptr, &crs);
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int r = 0; r < crs.num_rows; ++r)
    for (int k = crs.rows[static_cast<size_t>(r)]; k < crs.rows[static_cast<size_t>(r) + 1]; ++k)
      j(r, crs.cols[static_cast<size_t>(k)]) = crs.values[static_cast<size_t>(k)];
  out.jtj = j.transpose() * j;
  return out;
}

// The reported sums and angles with their uncertainties.
void FillDerived(const Parameterisation& param,
                 const Params& p,
                 const Eigen::MatrixXd& cov,
                 TrunnionFit* fit) {
  const Eigen::Matrix<double, 9, 1> g = Derived(param, p), u = DerivedU(param, p, cov);
  fit->c_x_mm = g[0], fit->c_y_mm = g[1], fit->a_y_mm = g[2], fit->a_z_mm = g[3];
  fit->c_x_u_mm = u[0], fit->c_y_u_mm = u[1], fit->a_y_u_mm = u[2], fit->a_z_u_mm = u[3];
  fit->a_about_z_deg = g[4], fit->a_about_y_deg = g[5], fit->c_about_x_deg = g[6];
  fit->c_about_y_deg = g[7], fit->a_c_square_deg = g[8];
  fit->a_about_z_u_deg = u[4], fit->a_about_y_u_deg = u[5], fit->c_about_x_u_deg = u[6];
  fit->c_about_y_u_deg = u[7], fit->a_c_square_u_deg = u[8];
  Vec3 on_a, on_c;
  Closest(fit->axes.a, fit->axes.c, &on_a, &on_c);
  fit->axes_apart_mm = (on_a - on_c).norm();
}

}  // namespace

TrunnionFit FitTrunnion(const std::vector<TrunnionObservation>& observations,
                        const TrunnionAxes& nominal,
                        const TrunnionFitOptions& options) {
  options.Check();
  CheckPlan(observations);
  const Parameterisation param(nominal);
  const Solution sol = Solve(observations, nominal, param, options.centre_sigma_mm);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sol.jtj);
  if (eig.eigenvalues()(0) <= 1e-10 * eig.eigenvalues()(kParams - 1))
    throw TrunnionError(
        "trunnion: the plan does not determine both lines (is the sphere on the C axis, or the "
        "A positions all one?)");
  TrunnionFit fit;
  fit.axes = param.Axes(sol.p);
  fit.sphere_table_mm = Vec3(sol.p[8], sol.p[9], sol.p[10]);
  fit.iterations = sol.iterations;
  double ss = 0.0;
  for (size_t i = 0; i < observations.size(); ++i) {
    const Vec3 d(sol.residuals[3 * i], sol.residuals[3 * i + 1], sol.residuals[3 * i + 2]);
    fit.residual_mm.push_back(d.norm() * options.centre_sigma_mm);
    ss += d.squaredNorm();
  }
  const double n = static_cast<double>(observations.size());
  fit.residual_rms_mm = std::sqrt(ss / n) * options.centre_sigma_mm;
  // The centres' own scatter once there are enough of them to say (2 residuals a parameter).
  const double dof = 3.0 * n - kParams;
  const double scale = dof >= 2.0 * kParams ? std::max(1.0, ss / dof) : 1.0;
  FillDerived(param, sol.p, sol.jtj.inverse() * scale, &fit);
  if (fit.residual_rms_mm > options.max_residual_rms_mm) {
    std::ostringstream why;
    why << "trunnion: the centres are " << fit.residual_rms_mm * 1e3
        << " um RMS from one point turned about two lines (limit "
        << options.max_residual_rms_mm * 1e3
        << " um): a loose sphere, a wrong pose or a move mid-plan";
    // The worst centre named, so the operator can look at that capture first.
    const auto worst = std::max_element(fit.residual_mm.begin(), fit.residual_mm.end());
    const TrunnionObservation& w =
        observations[static_cast<size_t>(worst - fit.residual_mm.begin())];
    why << "; the worst centre, A " << w.a_deg << " C " << w.c_deg << ", " << *worst * 1e3
        << " um off";
    throw TrunnionError(why.str());
  }
  return fit;
}

void TrunnionPlanOptions::Check() const {
  std::set<long> distinct;
  for (double a : a_deg) {
    if (!std::isfinite(a)) throw TrunnionError("trunnion plan: an A position is not finite");
    distinct.insert(std::lround(a * 1000));
  }
  if (distinct.size() < 3 || c_count < 3)
    throw TrunnionError("trunnion plan: three A positions and three C positions at least");
  if (!(probe_length_mm >= 0) || !(standoff_mm > 0) || !(table_radius_mm >= 0) ||
      !(margin_mm >= 0) || !std::isfinite(spindle_deg) || !std::isfinite(table_top_mm))
    throw TrunnionError("trunnion plan: lengths must be finite, the stand-off > 0");
}

TrunnionPlan PlanTrunnionCheck(const TrunnionAxes& axes,
                               const Vec3& sphere_table_mm,
                               const TrunnionPlanOptions& o) {
  o.Check();
  if (!sphere_table_mm.allFinite()) throw TrunnionError("trunnion plan: the sphere is not finite");
  TrunnionPlan plan;
  const Vec3 up(0.0, 0.0, o.probe_length_mm + o.standoff_mm);
  double highest = -std::numeric_limits<double>::infinity();  // of what the probe's tip passes
  for (double a : o.a_deg) {
    for (int k = 0; k < o.c_count; ++k) {
      const double c = 360.0 * k / o.c_count;
      const Vec3 gauge = MachineFromTable(axes, a, c) * sphere_table_mm + up;
      plan.stops.push_back({a, c, gauge});
      highest = std::max(highest, gauge.z() - o.probe_length_mm);
      // The rim's highest point at this tilt (turning C does not raise it): sampled round.
      for (int r = 0; r < 72 && o.table_radius_mm > 0; ++r) {
        const double t = 2 * kPi * r / 72;
        const Vec3 rim = axes.c.point + Vec3(o.table_radius_mm * std::cos(t),
                                             o.table_radius_mm * std::sin(t), 0.0);
        const Vec3 on_top(rim.x(), rim.y(), o.table_top_mm);
        highest = std::max(highest, (MachineFromTable(axes, a, c) * on_top).z());
      }
    }
  }
  plan.clear_gauge_z_mm = highest + o.margin_mm + o.probe_length_mm;
  return plan;
}

TrtPins PinsFor(const TrunnionFit& fit, const TrtPins& current) {
  TrtPins p = current;
  p.x_rot_point = fit.c_x_mm;
  p.y_rot_point = fit.c_y_mm;
  p.y_offset = fit.a_y_mm - fit.c_y_mm;
  p.z_offset = fit.a_z_mm - current.z_rot_point - current.tool_offset;
  return p;
}

PinCalibration CalibratePins(const TrunnionFit& fit,
                             const TrtPins& current,
                             double null_band_mm,
                             double max_change_mm) {
  const TrtPins to = PinsFor(fit, current);
  PinCalibration out;
  out.pins = current;
  const struct {
    const char* name;
    double TrtPins::*pin;
    double u_mm;
  } pins[] = {{"x-rot-point", &TrtPins::x_rot_point, fit.c_x_u_mm},
              {"y-rot-point", &TrtPins::y_rot_point, fit.c_y_u_mm},
              {"y-offset", &TrtPins::y_offset, std::hypot(fit.a_y_u_mm, fit.c_y_u_mm)},
              {"z-offset", &TrtPins::z_offset, fit.a_z_u_mm}};
  for (const auto& p : pins) {
    PinChange c{p.name, current.*p.pin, to.*p.pin, p.u_mm, false};
    const double change = c.after_mm - c.before_mm;
    c.changed = std::abs(change) > std::max(null_band_mm, 3 * c.u_mm);
    if (!c.changed) c.after_mm = c.before_mm;
    if (std::abs(change) > max_change_mm) {
      std::ostringstream why;
      why.setf(std::ios::fixed);
      why.precision(1);
      why << "the calibration would move " << c.name << " by " << change * 1e3
          << " um, beyond the machine's limit of " << max_change_mm * 1e3
          << " um: nothing written (a crash, a loose sphere, a wrong plan?)";
      out.problems.push_back(why.str());
    }
    out.pins.*p.pin = c.after_mm;
    out.changes.push_back(c);
  }
  return out;
}

std::string Describe(const TrunnionFit& fit, const TrtPins& current) {
  const TrtPins to = PinsFor(fit, current);
  std::ostringstream o;
  o.setf(std::ios::fixed);
  o.precision(1);
  const auto line = [&](const char* name, double now, double found, double u) {
    o << "  " << name << ": " << (found - now) * 1e3 << " um off (found +-" << u * 1e3
      << " um, k = 1)\n";
  };
  o << "trunnion over " << fit.residual_mm.size() << " sphere centres, residual "
    << fit.residual_rms_mm * 1e3 << " um RMS\n";
  line("x-rot-point", current.x_rot_point, to.x_rot_point, fit.c_x_u_mm);
  line("y-rot-point", current.y_rot_point, to.y_rot_point, fit.c_y_u_mm);
  line("y-offset", current.y_offset, to.y_offset, std::hypot(fit.a_y_u_mm, fit.c_y_u_mm));
  line("z-offset", current.z_offset, to.z_offset, fit.a_z_u_mm);
  o.precision(4);
  o << "  squareness the kinematics cannot hold: A from X " << fit.a_about_z_deg << " deg about Z, "
    << fit.a_about_y_deg << " deg about Y; C from Z " << fit.c_about_x_deg
    << " deg about X (as an A zero off), " << fit.c_about_y_deg << " deg about Y; A to C "
    << fit.a_c_square_deg << " deg from square\n";
  return o.str();
}

}  // namespace mlp::calib
