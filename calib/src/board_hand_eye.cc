#include "mlp/calib/board_hand_eye.h"

#include "mlp/base/units.h"
#include "mlp/geometry/columns.h"
#include "mlp/geometry/robust.h"
#include "mlp/probe_fw/probe_model.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include "robust_scale.h"
#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

namespace mlp::calib {
namespace {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

constexpr double kHuberSigmas = 3.0;
constexpr int kMinBoardViews = 3;

// Pose as 6 parameters: angle-axis rotation, then translation [mm].
std::array<double, 6> ToParams(const Pose3& p) {
  const Eigen::AngleAxisd aa(p.linear());
  const Vec3 r = aa.axis() * aa.angle();
  return {r.x(), r.y(), r.z(), p.translation().x(), p.translation().y(), p.translation().z()};
}

Pose3 FromParams(const double* q) {
  Pose3 p = Pose3::Identity();
  const Vec3 r(q[0], q[1], q[2]);
  const double angle = r.norm();
  if (angle > 0) p.linear() = Eigen::AngleAxisd(angle, r / angle).toRotationMatrix();
  p.translation() = Vec3(q[3], q[4], q[5]);
  return p;
}

template <typename T>
void Apply(const T* pose, const T* in, T* out) {  // pose * in
  ceres::AngleAxisRotatePoint(pose, in, out);
  for (int i = 0; i < 3; ++i) out[i] += pose[3 + i];
}

template <typename T>
void ApplyInverse(const T* pose, const T* in, T* out) {  // pose^-1 * in
  const T back[3] = {-pose[0], -pose[1], -pose[2]};
  const T shifted[3] = {in[0] - pose[3], in[1] - pose[4], in[2] - pose[5]};
  ceres::AngleAxisRotatePoint(back, shifted, out);
}

// The robot's pose error of an image as its own small pose D (angle-axis, translation [mm], in
// the flange frame): the true flange pose is F D. Errors-in-variables for the robot's poses, so
// that a robot cell's pose error (3 px at the blaser's board, six times its corner noise) lands
// in D_i instead of in X, and every corner and laser point keeps its own, independent noise.

// A board corner seen through X^-1 D^-1 F^-1 B, against where it was detected [px / sigma].
struct CornerCost {
  Intrinsics k;
  std::array<double, 6> flange_from_base;  // F^-1
  Vec3 corner;
  Vec2 seen;
  double sigma_px;
  template <typename T>
  bool operator()(const T* x, const T* b, const T* d, T* residual) const {
    const T c[3] = {T(corner.x()), T(corner.y()), T(corner.z())};
    T in_base[3], reported[3], in_flange[3], p[3];
    Apply(b, c, in_base);
    T f[6];
    for (int i = 0; i < 6; ++i) f[i] = T(flange_from_base[i]);
    Apply(f, in_base, reported);
    ApplyInverse(d, reported, in_flange);
    ApplyInverse(x, in_flange, p);
    const T xn = p[0] / p[2], yn = p[1] / p[2], r2 = xn * xn + yn * yn;
    const T radial = 1.0 + k.k1 * r2 + k.k2 * r2 * r2 + k.k3 * r2 * r2 * r2;
    const T xd = xn * radial + 2.0 * k.p1 * xn * yn + k.p2 * (r2 + 2.0 * xn * xn);
    const T yd = yn * radial + k.p1 * (r2 + 2.0 * yn * yn) + 2.0 * k.p2 * xn * yn;
    residual[0] = (k.fx_px * xd + k.cx_px - seen.x()) / sigma_px;
    residual[1] = (k.fy_px * yd + k.cy_px - seen.y()) / sigma_px;
    return true;
  }
};

// A stripe pixel's ray met with the light plane n.p = d, mapped by F D X: its height above the
// board [mm / sigma].
struct LaserCost {
  Vec3 ray;
  std::array<double, 6> base_from_flange;
  double sigma_mm;
  template <typename T>
  bool operator()(
      const T* x, const T* b, const T* normal, const T* offset, const T* d, T* residual) const {
    const T along = normal[0] * ray.x() + normal[1] * ray.y() + normal[2] * ray.z();
    const T s = offset[0] / along;
    const T p[3] = {s * ray.x(), s * ray.y(), s * ray.z()};
    T in_flange[3], reported[3], in_base[3], in_board[3];
    Apply(x, p, in_flange);
    Apply(d, in_flange, reported);
    T f[6];
    for (int i = 0; i < 6; ++i) f[i] = T(base_from_flange[i]);
    Apply(f, reported, in_base);
    ApplyInverse(b, in_base, in_board);
    residual[0] = in_board[2] / sigma_mm;
    return true;
  }
};

// The prior on an image's robot error: zero, with the robot's noise [rad], [mm].
struct RobotPrior {
  double sigma_rad, sigma_mm;
  template <typename T>
  bool operator()(const T* d, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = d[i] / sigma_rad;
    for (int i = 3; i < 6; ++i) residual[i] = d[i] / sigma_mm;
    return true;
  }
};

Pose3 ParkMartin(const std::vector<Pose3>& base_from_flange,
                 const std::vector<Pose3>& camera_from_board) {
  std::vector<cv::Mat> rg, tg, rc, tc;
  // A fresh cv::Mat per entry: eigen2cv writes into an existing matrix of the same size.
  const auto push = [](const Pose3& p, std::vector<cv::Mat>* rs, std::vector<cv::Mat>* ts) {
    cv::Mat r, t;
    cv::eigen2cv(Eigen::Matrix3d(p.linear()), r);
    cv::eigen2cv(Vec3(p.translation()), t);
    rs->push_back(r), ts->push_back(t);
  };
  for (size_t i = 0; i < base_from_flange.size(); ++i) {
    push(base_from_flange[i], &rg, &tg);
    push(camera_from_board[i], &rc, &tc);
  }
  cv::Mat rx, tx;
  cv::calibrateHandEye(rg, tg, rc, tc, rx, tx, cv::CALIB_HAND_EYE_PARK);
  Eigen::Matrix3d r;
  Vec3 t;
  cv::cv2eigen(rx, r);
  cv::cv2eigen(tx, t);
  Pose3 x = Pose3::Identity();
  x.linear() = r, x.translation() = t;
  return x;
}

std::vector<size_t> Thinned(size_t n, int max) {
  std::vector<size_t> out;
  const size_t step =
      std::max<size_t>(1, (n + static_cast<size_t>(max) - 1) / static_cast<size_t>(max));
  for (size_t i = 0; i < n; i += step) out.push_back(i);
  return out;
}

std::vector<Vec3> BoardCorners(const ChessboardSpec& b) {
  std::vector<Vec3> out;
  for (int j = 1; j <= b.inner_rows; ++j)
    for (int i = 1; i <= b.inner_cols; ++i) out.emplace_back(i * b.square_mm, j * b.square_mm, 0.0);
  return out;
}

}  // namespace

std::vector<Vec3> LaserPointsInBase(const ImageFindings& f,
                                    const Pose3& base_from_flange,
                                    const Intrinsics& camera,
                                    const geometry::Plane& plane,
                                    const Pose3& flange_from_camera) {
  const probe_fw::CameraModel cam = CameraModelOf(camera);
  const Vec3 n = plane.normal.normalized();
  const double d = n.dot(plane.point);
  const Pose3 base_from_camera = base_from_flange * flange_from_camera;
  std::vector<Vec3> out;
  for (const auto& px : f.stripe_px) {
    const Vec2 u = cam.Undistort(px);
    const Vec3 ray(u.x(), u.y(), 1.0);
    const double along = n.dot(ray);
    if (std::abs(along) < 1e-9) continue;  // a ray in the plane: no intersection
    out.push_back(base_from_camera * (ray * (d / along)));
  }
  return out;
}

Spread SpreadAboutCommonPlane(const std::vector<Vec3>& points) {
  Spread s;
  if (points.size() < 3) return s;
  const auto fit = geometry::FitPlaneRobust(geometry::AsColumns(points));
  double s2 = 0.0;
  for (int i : fit.inliers) {
    const Vec3& p = points[static_cast<size_t>(i)];
    const double e = std::abs(fit.fit.shape.normal.dot(p - fit.fit.shape.point));
    s2 += e * e, s.max_mm = std::max(s.max_mm, e);
  }
  s.points = static_cast<int>(fit.inliers.size());
  s.outliers = static_cast<int>(points.size() - fit.inliers.size());
  s.rms_mm = s.points > 0 ? std::sqrt(s2 / double(s.points)) : 0.0;
  s.threshold_mm = fit.threshold_mm;
  s.plane = fit.fit.shape;
  double all2 = 0.0;
  for (const Vec3& p : points) {
    const double e = std::abs(s.plane.normal.dot(p - s.plane.point));
    all2 += e * e, s.all_max_mm = std::max(s.all_max_mm, e);
  }
  s.all_rms_mm = std::sqrt(all2 / double(points.size()));
  return s;
}

Spread CornerSpreadInBase(const std::vector<Pose3>& camera_from_board,
                          const std::vector<Pose3>& base_from_flange,
                          const Pose3& x,
                          const ChessboardSpec& board) {
  Spread s;
  const auto corners = BoardCorners(board);
  const size_t views = camera_from_board.size();
  if (views == 0) return s;
  double s2 = 0.0;
  for (const Vec3& c : corners) {
    std::vector<Vec3> mapped;
    Vec3 mean = Vec3::Zero();
    for (size_t v = 0; v < views; ++v) {
      mapped.push_back(base_from_flange[v] * x * camera_from_board[v] * c);
      mean += mapped.back();
    }
    mean /= double(views);
    for (const auto& p : mapped) {
      const double e = (p - mean).norm();
      s2 += e * e, s.max_mm = std::max(s.max_mm, e), ++s.points;
    }
  }
  s.rms_mm = std::sqrt(s2 / s.points);
  return s;
}

namespace {

// The unknowns of the joint problem: X, B, the light plane n.p = d (camera frame), and each
// image's robot error D_i (zero for an image that adds nothing).
struct JointParams {
  std::array<double, 6> x{}, b{};
  Vec3 n = Vec3::UnitZ();
  double d = 0.0;
  std::vector<std::array<double, 6>> robot;
};

// The noise of each class: corners [px] and laser heights [mm], the sensor's, independent per
// point; the robot's pose error per image [rad], [mm].
struct ClassSigmas {
  double px = 1.0, mm = 1.0, robot_rad = 1.0, robot_mm = 1.0;
};

constexpr double kMinSigmaPx = 0.01, kMinSigmaMm = 0.0005, kMinRobotMm = 0.0005;

// One joint least-squares problem over JointParams at given class noise.
class JointProblem {
 public:
  JointProblem(const std::vector<ImageFindings>& findings,
               const std::vector<RobotImage>& images,
               const LineLaserCalibration& cal,
               const ChessboardSpec& board,
               const BoardHandEyeOptions& o,
               ClassSigmas sigmas,
               JointParams* p)
      : huber_(kHuberSigmas), sigmas_(sigmas), p_(p) {
    ceres::Problem::Options po;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(po);
    AddCorners(findings, images, cal, board);
    AddLaser(findings, images, cal, o);
    for (size_t i = 0; i < findings.size(); ++i) {
      if (!problem_->HasParameterBlock(p_->robot[i].data())) continue;
      problem_->AddResidualBlock(new ceres::AutoDiffCostFunction<RobotPrior, 6, 6>(
                                     new RobotPrior{sigmas_.robot_rad, sigmas_.robot_mm}),
                                 nullptr, p_->robot[i].data());
      used_.push_back(i);
    }
    if (!laser_.empty()) {
      problem_->SetManifold(p_->n.data(), new ceres::SphereManifold<3>());
      if (!o.refine_plane) {
        problem_->SetParameterBlockConstant(p_->n.data());
        problem_->SetParameterBlockConstant(&p_->d);
      }
    }
  }

  ceres::Solver::Summary Solve() {
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;  // the robot errors eliminated image by image
    so.max_num_iterations = 200;
    so.function_tolerance = 1e-12;
    so.parameter_tolerance = 1e-12;
    ceres::Solver::Summary summary;
    ceres::Solve(so, problem_.get(), &summary);
    return summary;
  }

  // Each class's noise as the solution shows it (variance components, Helmert; Foerstner 1979):
  // 1.4826 x the median |residual| for the sensor's classes (robust to the laser light beside
  // the board), and the RMS of the robot errors' translations, at most `robot_cap_mm`: a weak
  // prior lets the per-image errors absorb X, which raises their scale and weakens the prior
  // further (on the blaser images, unbounded, it ran away to 32 mm).
  ClassSigmas ResidualSigmas(double robot_cap_mm) const {
    ClassSigmas s;
    s.px = std::max(kMinSigmaPx, sigmas_.px * RobustSigma(Residuals(corners_)));
    s.mm = laser_.empty() ? sigmas_.mm
                          : std::max(kMinSigmaMm, sigmas_.mm * RobustSigma(Residuals(laser_)));
    // The robot's translation noise; its rotation noise is given: at the camera the two are
    // nearly the same motion, and estimated apart one of them collapsed to zero, estimated as
    // one (rotations at the lever arm) the rotations took up the camera model's own errors on
    // the blaser images (0.2 deg per image, the corners' spread doubled).
    std::vector<double> all;
    for (size_t i : used_)
      for (int k = 3; k < 6; ++k) all.push_back(p_->robot[i][size_t(k)]);
    s.robot_mm = std::clamp(Rms(all), kMinRobotMm, robot_cap_mm);
    s.robot_rad = sigmas_.robot_rad;  // given (BoardHandEyeOptions), not estimated
    return s;
  }

  ceres::Problem& problem() { return *problem_; }
  int corners() const { return static_cast<int>(corners_.size()); }
  int laser_points() const { return static_cast<int>(laser_.size()); }

 private:
  static double Rms(const std::vector<double>& v) {
    double s2 = 0.0;
    for (double e : v) s2 += e * e;
    return v.empty() ? 0.0 : std::sqrt(s2 / double(v.size()));
  }

  void AddCorners(const std::vector<ImageFindings>& findings,
                  const std::vector<RobotImage>& images,
                  const LineLaserCalibration& cal,
                  const ChessboardSpec& board) {
    const auto corners = BoardCorners(board);
    for (int index : cal.board_images) {
      const size_t i = static_cast<size_t>(index);
      const auto flange_from_base = ToParams(images[i].base_from_flange.inverse());
      for (size_t c = 0; c < corners.size(); ++c) {
        auto* cost = new ceres::AutoDiffCostFunction<CornerCost, 2, 6, 6, 6>(
            new CornerCost{cal.camera.intrinsics, flange_from_base, corners[c],
                           findings[i].corners[c], sigmas_.px});
        corners_.push_back(problem_->AddResidualBlock(cost, &huber_, p_->x.data(), p_->b.data(),
                                                      p_->robot[i].data()));
      }
    }
  }

  void AddLaser(const std::vector<ImageFindings>& findings,
                const std::vector<RobotImage>& images,
                const LineLaserCalibration& cal,
                const BoardHandEyeOptions& o) {
    const probe_fw::CameraModel cam = CameraModelOf(cal.camera.intrinsics);
    for (size_t i = 0; i < findings.size(); ++i) {
      const ImageFindings& f = findings[i];
      if (!f.HasLaser()) continue;
      for (size_t j : Thinned(f.stripe_px.size(), o.max_laser_points_per_image)) {
        const Vec2 u = cam.Undistort(f.stripe_px[j]);
        auto* cost = new ceres::AutoDiffCostFunction<LaserCost, 1, 6, 6, 3, 1, 6>(new LaserCost{
            Vec3(u.x(), u.y(), 1.0), ToParams(images[i].base_from_flange), sigmas_.mm});
        laser_.push_back(problem_->AddResidualBlock(cost, &huber_, p_->x.data(), p_->b.data(),
                                                    p_->n.data(), &p_->d, p_->robot[i].data()));
      }
    }
  }

  // The blocks' residuals times their class sigma over the one they were built with, without
  // the loss.
  std::vector<double> Residuals(const std::vector<ceres::ResidualBlockId>& blocks) const {
    ceres::Problem::EvaluateOptions eo;
    eo.residual_blocks = blocks;
    eo.apply_loss_function = false;
    std::vector<double> r;
    problem_->Evaluate(eo, nullptr, &r, nullptr, nullptr);
    return r;
  }

  ceres::HuberLoss huber_;
  ClassSigmas sigmas_;
  JointParams* p_;
  std::unique_ptr<ceres::Problem> problem_;
  std::vector<ceres::ResidualBlockId> corners_, laser_;
  std::vector<size_t> used_;  ///< images with a robot error in the problem
};

constexpr int kMaxVariancePasses = 10;
constexpr double kSigmaSettled = 0.02;  // relative change of every class sigma between passes

bool Settled(const ClassSigmas& a, const ClassSigmas& b) {
  const auto close = [](double u, double v) { return std::abs(u / v - 1.0) < kSigmaSettled; };
  return close(a.px, b.px) && close(a.mm, b.mm) && close(a.robot_mm, b.robot_mm);
}

void CheckBoardInput(const std::vector<ImageFindings>& findings,
                     const std::vector<RobotImage>& images,
                     const LineLaserCalibration& cal) {
  using Kind = HandEyeError::Kind;
  if (findings.size() != images.size())
    throw HandEyeError(Kind::kBadInput, "board hand-eye: one pose per image is needed");
  if (static_cast<int>(cal.board_images.size()) < kMinBoardViews)
    throw HandEyeError(Kind::kBadInput, "board hand-eye: the board was used in " +
                                            std::to_string(cal.board_images.size()) +
                                            " images; at least 3 with different orientations");
}

// The start: AX = XB (Park & Martin) from the board views, B through the first of them, the
// light plane from the line-laser calibration, no robot error.
JointParams StartParams(const std::vector<ImageFindings>& findings,
                        const std::vector<Pose3>& flange_poses,
                        const LineLaserCalibration& cal,
                        const Pose3& start_flange_from_camera) {
  JointParams p;
  p.x = ToParams(start_flange_from_camera);
  p.b = ToParams(flange_poses[0] * start_flange_from_camera * cal.camera.camera_from_board[0]);
  p.n = cal.plane.normal.normalized();
  p.d = p.n.dot(cal.plane.point);
  p.robot.assign(findings.size(), std::array<double, 6>{});
  return p;
}

// Joint solves until every class's noise settles (variance components): each pass weighs the
// corners, the laser and the robot by the sigmas the last pass saw. Returns the last problem.
std::unique_ptr<JointProblem> SolveUntilSigmasSettle(const std::vector<ImageFindings>& findings,
                                                     const std::vector<RobotImage>& images,
                                                     const LineLaserCalibration& cal,
                                                     const ChessboardSpec& board,
                                                     const BoardHandEyeOptions& o,
                                                     double robot_cap_mm,
                                                     ClassSigmas* sigmas,
                                                     JointParams* p,
                                                     BoardHandEyeResult* r) {
  std::unique_ptr<JointProblem> joint;
  for (int pass = 0; pass < kMaxVariancePasses; ++pass) {
    joint = std::make_unique<JointProblem>(findings, images, cal, board, o, *sigmas, p);
    const ceres::Solver::Summary summary = joint->Solve();
    r->iterations += static_cast<int>(summary.iterations.size());
    if (!summary.IsSolutionUsable())
      throw HandEyeError(HandEyeError::Kind::kBadInput,
                         "board hand-eye: the solver failed: " + summary.message);
    const ClassSigmas seen = joint->ResidualSigmas(robot_cap_mm);
    ++r->variance_passes;
    if (Settled(seen, *sigmas)) break;
    *sigmas = seen;
  }
  return joint;
}

// Observability: X's covariance (the robot's errors and the plane marginalised), not scaled by
// a variance factor (every class's noise was estimated from the solution already). Throws when
// the least determined combination, rotations at the lever arm, is above the limit.
void MountingCovariance(ceres::Problem* problem,
                        std::array<double, 6>* x,
                        const BoardHandEyeOptions& o,
                        BoardHandEyeResult* r) {
  using Kind = HandEyeError::Kind;
  ceres::Covariance::Options co;
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {{x->data(), x->data()}};
  double c[36];
  if (!covariance.Compute(blocks, problem) ||
      !covariance.GetCovarianceBlock(x->data(), x->data(), c))
    throw HandEyeError(Kind::kUnderDetermined,
                       "board hand-eye: the mounting is not determined (rank-deficient): "
                       "the board views need rotations about two different axes");
  r->covariance = Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(c);
  Eigen::Matrix<double, 6, 6> scaled = r->covariance;
  scaled.topRows<3>() *= o.lever_mm;
  scaled.leftCols<3>() *= o.lever_mm;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(scaled);
  r->worst_std_mm = std::sqrt(std::max(0.0, eig.eigenvalues()(5)));
  if (r->worst_std_mm <= o.max_std_mm) return;
  static const char* names[6] = {"rx", "ry", "rz", "tx", "ty", "tz"};
  int dominant = 0;
  eig.eigenvectors().col(5).cwiseAbs().maxCoeff(&dominant);
  std::ostringstream msg;
  msg << "board hand-eye: the mounting is determined to " << r->worst_std_mm
      << " mm (1 sigma, rotations at " << o.lever_mm << " mm), above " << o.max_std_mm
      << " mm; mostly " << names[dominant]
      << ": add board views turned about another axis, or farther apart";
  throw HandEyeError(Kind::kUnderDetermined, msg.str());
}

// Image i's corners through the solution: their squared reprojection errors [px^2] summed.
double CornerSquares(const ImageFindings& f,
                     const Pose3& base_from_flange,
                     const BoardHandEyeResult& r,
                     const Intrinsics& k,
                     const std::vector<Vec3>& corners) {
  const Pose3 camera_from_board =
      (base_from_flange * r.flange_from_camera).inverse() * r.base_from_board;
  double s2 = 0.0;
  for (size_t n = 0; n < corners.size(); ++n)
    s2 += (k.Project(camera_from_board * corners[n]) - f.corners[n]).squaredNorm();
  return s2;
}

// Image i's laser points' heights above the solved board [mm].
// Heights [mm] of `points_in_base` above the board at `base_from_board`: mean, RMS, largest.
void Heights(const std::vector<Vec3>& points_in_base,
             const Pose3& base_from_board,
             double* mean,
             double* rms,
             double* max) {
  const Pose3 board_from_base = base_from_board.inverse();
  double sum = 0.0, s2 = 0.0;
  for (const Vec3& p : points_in_base) {
    const double h = (board_from_base * p).z();
    sum += h, s2 += h * h, *max = std::max(*max, std::abs(h));
  }
  const auto n = static_cast<double>(std::max<size_t>(points_in_base.size(), 1));
  *mean = sum / n, *rms = std::sqrt(s2 / n);
}

void LaserHeights(const ImageFindings& f,
                  const Pose3& base_from_flange,
                  const BoardHandEyeResult& r,
                  const Intrinsics& k,
                  BoardHandEyeImage* im) {
  const std::vector<Vec3> points =
      LaserPointsInBase(f, base_from_flange, k, r.plane, r.flange_from_camera);
  double mean = 0.0;
  Heights(points, r.base_from_board, &mean, &im->laser_rms_mm, &im->laser_max_mm);
  im->laser_points = static_cast<int>(points.size());
}

// Per image: the robot error found, corners through the solution, laser heights above the board.
void PerImageResiduals(const std::vector<ImageFindings>& findings,
                       const std::vector<RobotImage>& images,
                       const LineLaserCalibration& cal,
                       const ChessboardSpec& board,
                       const JointParams& p,
                       BoardHandEyeResult* r) {
  double corner_sum2 = 0.0;
  int corner_count = 0;
  const auto corners = BoardCorners(board);
  const Intrinsics& k = cal.camera.intrinsics;
  for (size_t i = 0; i < findings.size(); ++i) {
    const ImageFindings& f = findings[i];
    BoardHandEyeImage im;
    im.name = f.name;
    const Pose3 d = FromParams(p.robot[i].data());
    im.robot_error_mm = d.translation().norm();
    im.robot_error_deg = Eigen::AngleAxisd(d.linear()).angle() * base::kDegPerRad;
    const auto used = std::find(cal.board_images.begin(), cal.board_images.end(), int(i));
    if (used != cal.board_images.end()) {
      const double s2 = CornerSquares(f, images[i].base_from_flange, *r, k, corners);
      im.corners = static_cast<int>(corners.size());
      im.corner_rms_px = std::sqrt(s2 / double(corners.size()));
      corner_sum2 += s2, corner_count += im.corners;
    }
    if (f.HasLaser()) LaserHeights(f, images[i].base_from_flange, *r, k, &im);
    r->images.push_back(im);
  }
  r->corner_rms_px = corner_count > 0 ? std::sqrt(corner_sum2 / corner_count) : 0.0;
}

}  // namespace

BoardHandEyeResult SolveBoardHandEye(const std::vector<ImageFindings>& findings,
                                     const std::vector<RobotImage>& images,
                                     const LineLaserCalibration& cal,
                                     const ChessboardSpec& board,
                                     const BoardHandEyeOptions& o) {
  CheckBoardInput(findings, images, cal);
  BoardHandEyeResult r;
  std::vector<Pose3> flange_poses;
  for (int i : cal.board_images)
    flange_poses.push_back(images[static_cast<size_t>(i)].base_from_flange);
  r.start_flange_from_camera = ParkMartin(flange_poses, cal.camera.camera_from_board);
  if (!r.start_flange_from_camera.matrix().allFinite())
    throw HandEyeError(HandEyeError::Kind::kUnderDetermined,
                       "board hand-eye: AX = XB has no solution from these views: the board "
                       "views need rotations about two different axes");
  JointParams p = StartParams(findings, flange_poses, cal, r.start_flange_from_camera);
  // The robot's noise starts from the corners' spread in the base through the start (each
  // view's board pose, F_i and X): the pose error is most of it.
  const Spread start = CornerSpreadInBase(cal.camera.camera_from_board, flange_poses,
                                          r.start_flange_from_camera, board);
  const double robot_cap_mm = std::max(kMinRobotMm, start.rms_mm);
  ClassSigmas sigmas{std::max(0.05, cal.camera.rms_reprojection_px),
                     std::max(0.005, cal.plane_rms_mm),
                     o.robot_rotation_sigma_deg / base::kDegPerRad, robot_cap_mm};
  const std::unique_ptr<JointProblem> joint =
      SolveUntilSigmasSettle(findings, images, cal, board, o, robot_cap_mm, &sigmas, &p, &r);
  r.corner_sigma_px = sigmas.px, r.laser_sigma_mm = sigmas.mm;
  r.robot_sigma_mm = sigmas.robot_mm, r.robot_sigma_deg = sigmas.robot_rad * base::kDegPerRad;
  r.corners_used = joint->corners(), r.laser_points_used = joint->laser_points();
  r.flange_from_camera = FromParams(p.x.data());
  r.base_from_board = FromParams(p.b.data());
  r.plane.normal = p.n.normalized();
  r.plane.point = r.plane.normal * p.d;
  MountingCovariance(&joint->problem(), &p.x, o, &r);
  PerImageResiduals(findings, images, cal, board, p, &r);
  return r;
}

namespace {

constexpr double kLaserBeyondSigmas = 2.5, kMinLaserBeyondMm = 0.1;

}  // namespace

BoardImageCheck CheckBoardImage(const ImageFindings& f,
                                const Pose3& base_from_flange,
                                const Intrinsics& camera,
                                const geometry::Plane& plane_in_camera,
                                const Pose3& flange_from_camera,
                                const Pose3& base_from_board,
                                const ChessboardSpec& board) {
  if (!f.HasBoard())
    throw CameraCalibError(f.name + ": no board found in the image; the check needs the board");
  BoardImageCheck c;
  const CameraCalibration seen = BoardPosesWithCamera({f.corners}, board, camera);
  c.camera_from_board_seen = seen.camera_from_board.at(0);
  c.seen_corner_rms_px = seen.view_rms_px.at(0);
  const std::vector<Vec3> corners = BoardCorners(board);
  const Pose3 base_from_camera = base_from_flange * flange_from_camera;
  BoardHandEyeResult expected;
  expected.flange_from_camera = flange_from_camera, expected.base_from_board = base_from_board;
  c.expected_corner_rms_px =
      std::sqrt(CornerSquares(f, base_from_flange, expected, camera, corners) /
                static_cast<double>(corners.size()));
  const Vec3 middle = 0.5 * (corners.front() + corners.back());
  const Pose3 base_from_board_seen = base_from_camera * c.camera_from_board_seen;
  c.board_offset_mm = (base_from_board_seen * middle - base_from_board * middle).norm();
  c.board_turn_deg =
      Eigen::AngleAxisd(base_from_board_seen.linear() * base_from_board.linear().transpose())
          .angle() *
      180.0 / M_PI;
  // The points near the seen board's plane by a robust rule; the rest fell beside the board.
  const std::vector<Vec3> all =
      LaserPointsInBase(f, base_from_flange, camera, plane_in_camera, flange_from_camera);
  double unused = 0.0;
  Heights(all, base_from_board_seen, &unused, &c.laser_all_rms_mm, &c.laser_all_max_mm);
  const Pose3 board_seen_from_base = base_from_board_seen.inverse();
  std::vector<double> h;
  h.reserve(all.size());
  for (const Vec3& p : all) h.push_back((board_seen_from_base * p).z());
  c.laser_left_out_beyond_mm =
      h.empty() ? 0.0 : std::max(kMinLaserBeyondMm, kLaserBeyondSigmas * RobustSigma(h));
  std::vector<Vec3> laser;
  for (size_t k = 0; k < all.size(); ++k)
    if (std::abs(h[k]) <= c.laser_left_out_beyond_mm) laser.push_back(all[k]);
  c.laser_left_out = static_cast<int>(all.size() - laser.size());
  c.laser_points = static_cast<int>(laser.size());
  Heights(laser, base_from_board_seen, &unused, &c.laser_seen_rms_mm, &c.laser_seen_max_mm);
  Heights(laser, base_from_board, &c.laser_expected_mean_mm, &c.laser_expected_rms_mm,
          &c.laser_expected_max_mm);
  return c;
}

}  // namespace mlp::calib
