#include "mlp/calib/probe_calib.h"

#include "mlp/base/units.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

namespace mlp::calib {
namespace {

using geometry::Pose3;
using geometry::Vec2;
using geometry::Vec3;

// Noise assumed for the weights: corner 0.06 px, stripe 0.03 projector column (what the
// virtual probe's reference noise produces; only their ratio matters to the solution).
constexpr double kCornerSigmaPx = 0.06;
constexpr double kStripeSigmaColumns = 0.03;
constexpr int kUndistortIterations = 20;
// Stripe points on uniform light: +-8 px along the row (twice the centroid window) within 85 %
// of the brightest, which is at least a quarter of full scale (a light square, not a dark one).
constexpr int kUniformHalfPx = 8;
constexpr double kUniformRatio = 0.85;
constexpr std::size_t kMaxStripePoints = 15000;

// Camera parameters: fx fy cx cy k1 k2 p1 p2 k3.
template <class T>
void Distort(const T* k, const T& x, const T& y, T* xd, T* yd) {
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (k[4] + r2 * (k[5] + r2 * k[8]));
  *xd = x * radial + T(2) * k[6] * x * y + k[7] * (r2 + T(2) * x * x);
  *yd = y * radial + k[6] * (r2 + T(2) * y * y) + T(2) * k[7] * x * y;
}

// Fixed-point inversion of the distortion (OpenCV's scheme, run to convergence): a lens's
// distortion is a small perturbation, so 20 steps reach 1e-12 on the reference probe.
template <class T>
void Undistort(const T* k, double u, double v, T* x, T* y) {
  const T xd = (T(u) - k[2]) / k[0], yd = (T(v) - k[3]) / k[1];
  *x = xd, *y = yd;
  for (int it = 0; it < kUndistortIterations; ++it) {
    T dx, dy;
    Distort(k, *x, *y, &dx, &dy);
    *x += xd - dx;
    *y += yd - dy;
  }
}

struct CornerResidual {
  Vec3 corner_in_board;
  Vec2 observed;
  template <class T>
  bool operator()(const T* k, const T* board_r, const T* board_t, T* r) const {
    const T p[3] = {T(corner_in_board.x()), T(corner_in_board.y()), T(0)};
    T c[3];
    ceres::AngleAxisRotatePoint(board_r, p, c);
    for (int i = 0; i < 3; ++i) c[i] += board_t[i];
    T xd, yd;
    Distort(k, c[0] / c[2], c[1] / c[2], &xd, &yd);
    r[0] = (k[0] * xd + k[2] - T(observed.x())) / T(kCornerSigmaPx);
    r[1] = (k[1] * yd + k[3] - T(observed.y())) / T(kCornerSigmaPx);
    return true;
  }
};

// Projector: f, c, mirror cubic, smile | rotation vector and translation of
// camera_from_projector. The observed (commanded) column's actual column must be the sheet
// column of the point: its planar column less the smile at its place along the line.
struct StripeResidual {
  StripeObservation s;
  double half_columns;  // columns / 2: the mirror's cubic is in s = (u - c) / (columns / 2)
  double tan_fan;       // tan of the fan's half angle: the smile is in t / tan_fan
  template <class T>
  bool operator()(const T* k,
                  const T* board_r,
                  const T* board_t,
                  const T* proj,
                  const T* proj_r,
                  const T* proj_t,
                  T* r) const {
    T x, y;
    Undistort(k, s.x_px, s.y_px, &x, &y);
    // The board plane in the camera frame: normal R e_z through t.
    const T ez[3] = {T(0), T(0), T(1)};
    T n[3];
    ceres::AngleAxisRotatePoint(board_r, ez, n);
    const T facing = n[0] * x + n[1] * y + n[2];
    const T dist = n[0] * board_t[0] + n[1] * board_t[1] + n[2] * board_t[2];
    const T scale = dist / facing;
    const T X[3] = {scale * x - proj_t[0], scale * y - proj_t[1], scale - proj_t[2]};
    const T minus_r[3] = {-proj_r[0], -proj_r[1], -proj_r[2]};
    T q[3];
    ceres::AngleAxisRotatePoint(minus_r, X, q);  // projector_from_camera
    const T along = q[1] / q[2] / T(tan_fan);
    const T sheet = proj[1] + proj[0] * q[0] / q[2] - proj[3] * along * along;
    const T mirror = (T(s.column) - proj[1]) / T(half_columns);
    const T actual = T(s.column) + proj[2] * mirror * mirror * mirror;
    r[0] = (sheet - actual) / T(kStripeSigmaColumns);
    return true;
  }
};

void ToAngleAxis(const Pose3& p, double* r, double* t) {
  const Eigen::AngleAxisd aa(p.linear());
  const Vec3 v = aa.axis() * aa.angle();
  for (int i = 0; i < 3; ++i) r[i] = v(i), t[i] = p.translation()(i);
}

Pose3 FromAngleAxis(const double* r, const double* t) {
  const Vec3 v(r[0], r[1], r[2]);
  Pose3 p = Pose3::Identity();
  if (v.norm() > 0) p.linear() = Eigen::AngleAxisd(v.norm(), v.normalized()).toRotationMatrix();
  p.translation() = Vec3(t[0], t[1], t[2]);
  return p;
}

void Solve(ceres::Problem* problem, ProbeCalibResult* result) {
  ceres::Solver::Options o;
  o.linear_solver_type = ceres::SPARSE_SCHUR;
  o.max_num_iterations = 200;
  o.function_tolerance = 1e-15;
  o.parameter_tolerance = 1e-15;
  o.gradient_tolerance = 1e-15;
  ceres::Solver::Summary summary;
  ceres::Solve(o, problem, &summary);
  if (summary.termination_type == ceres::FAILURE)
    throw CameraCalibError("the adjustment failed: " + summary.message);
  result->iterations += static_cast<int>(summary.iterations.size());
}

// 1-sigma of the mirror's cubic and the smile (proj[2], proj[3]) in their own units, scaled by
// the fit's residual variance; infinite when the problem cannot say.
std::array<double, 2> SheetTermStd(ceres::Problem* problem, double* proj) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;  // a gauge freedom (the projector along its line) is no failure
  ceres::Covariance covariance(co);
  const std::vector<std::pair<const double*, const double*>> blocks = {{proj, proj}};
  if (!covariance.Compute(blocks, problem)) return {INFINITY, INFINITY};
  double c[16];
  covariance.GetCovarianceBlock(proj, proj, c);
  double cost = 0.0;
  problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
  const double dof = std::max(1, problem->NumResiduals() - problem->NumParameters());
  const double variance = 2.0 * cost / dof;  // Ceres' cost is half the sum of squares
  return {std::sqrt(c[10] * variance), std::sqrt(c[15] * variance)};
}

// The mirror's cubic and the smile are kept only where the views determine them: a cubic fitted
// to stripes in the middle of the mirror's range is extrapolated to its ends, where it does more
// harm than the design's zero. A term determined worse than the limit is held at its start and
// the adjustment solved again.
void CheckSheetTerms(const ProbeCalibInput& in,
                     double* proj,
                     ceres::Problem* problem,
                     ProbeCalibResult* result) {
  const ProjectorParams& p0 = in.projector_start;
  const auto sigma = SheetTermStd(problem, proj);
  // The smile's effect at the camera's field edge: t there is about cy / fy (half the height).
  const double edge_t = in.camera_start.cy_px / in.camera_start.fy_px;
  const double edge_r = edge_t / std::tan(p0.fan_half_angle_deg / base::kDegPerRad);
  result->mirror_cubic_std_cols = sigma[0];
  result->smile_std_cols = sigma[1] * edge_r * edge_r;
  std::vector<int> held;
  const auto say = [&](const char* what, double std_cols, double start) {
    std::ostringstream m;
    m.precision(3);
    m << what << " not determined by these views (1-sigma " << std_cols << " columns, limit "
      << in.max_term_std_cols << "): held at " << start
      << "; views whose stripes span the mirror's range and the field determine it";
    result->notes.push_back(m.str());
  };
  if (!(result->mirror_cubic_std_cols <= in.max_term_std_cols)) {
    held.push_back(2), proj[2] = p0.mirror_cubic_cols;
    say("the mirror's cubic", result->mirror_cubic_std_cols, p0.mirror_cubic_cols);
  }
  if (!(result->smile_std_cols <= in.max_term_std_cols)) {
    held.push_back(3), proj[3] = p0.sheet_smile_cols;
    say("the sheet's smile", result->smile_std_cols, p0.sheet_smile_cols);
  }
  if (held.empty()) return;
  problem->SetManifold(proj, new ceres::SubsetManifold(4, held));
  Solve(problem, result);
}

// The adjustment's parameter blocks: the camera (fx fy cx cy k1 k2 p1 p2 k3), the projector
// (f, c, the mirror's cubic, the sheet's smile), its pose in the camera (angle-axis, mm) and
// each view's board pose (angle-axis, mm).
struct JointBlocks {
  double k[9];
  double proj[4];
  double proj_r[3], proj_t[3];
  std::vector<std::array<double, 6>> boards;
};

JointBlocks StartBlocks(const ProbeCalibInput& in) {
  const Intrinsics& c0 = in.camera_start;
  const ProjectorParams& p0 = in.projector_start;
  JointBlocks b{{c0.fx_px, c0.fy_px, c0.cx_px, c0.cy_px, c0.k1, c0.k2, c0.p1, c0.p2, c0.k3},
                {p0.f_px, p0.c_px, p0.mirror_cubic_cols, p0.sheet_smile_cols},
                {},
                {},
                std::vector<std::array<double, 6>>(in.corners.size())};
  ToAngleAxis(p0.camera_from_projector, b.proj_r, b.proj_t);
  for (size_t v = 0; v < b.boards.size(); ++v)
    ToAngleAxis(in.camera_from_board_start[v], b.boards[v].data(), b.boards[v].data() + 3);
  return b;
}

// One residual block per board corner of every view the board was found in.
void AddCorners(const ProbeCalibInput& in,
                JointBlocks* b,
                ceres::Problem* problem,
                ProbeCalibResult* result) {
  for (size_t v = 0; v < in.corners.size(); ++v) {
    if (in.corners[v].empty()) continue;
    ++result->views_used;
    size_t idx = 0;
    for (int j = 1; j <= in.board.inner_rows; ++j) {
      for (int i = 1; i <= in.board.inner_cols; ++i, ++idx) {
        const Vec3 corner(i * in.board.square_mm, j * in.board.square_mm, 0.0);
        problem->AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 9, 3, 3>(
                                      new CornerResidual{corner, in.corners[v][idx]}),
                                  nullptr, b->k, b->boards[v].data(), b->boards[v].data() + 3);
        ++result->corners_used;
      }
    }
  }
  if (result->views_used < 4) throw CameraCalibError("the board was found in fewer than 4 views");
}

// One residual block per stripe point on a found board: its column against the light plane's.
void AddStripes(const ProbeCalibInput& in,
                JointBlocks* b,
                ceres::Problem* problem,
                ProbeCalibResult* result) {
  const ProjectorParams& p0 = in.projector_start;
  const double half_columns = p0.columns > 0 ? 0.5 * p0.columns : 1.0;
  const double tan_fan = std::tan(p0.fan_half_angle_deg / base::kDegPerRad);
  for (const StripeObservation& s : in.stripes) {
    if (s.view < 0 || static_cast<size_t>(s.view) >= in.corners.size() ||
        in.corners[s.view].empty())
      continue;
    auto& board = b->boards[static_cast<size_t>(s.view)];
    problem->AddResidualBlock(new ceres::AutoDiffCostFunction<StripeResidual, 1, 9, 3, 3, 4, 3, 3>(
                                  new StripeResidual{s, half_columns, tan_fan}),
                              nullptr, b->k, board.data(), board.data() + 3, b->proj, b->proj_r,
                              b->proj_t);
    ++result->stripes_used;
  }
  if (result->stripes_used == 0) throw CameraCalibError("no stripe point on a found board");
}

void ReadBack(const JointBlocks& b, const ProjectorParams& p0, ProbeCalibResult* result) {
  auto& c = result->camera;
  c.fx_px = b.k[0], c.fy_px = b.k[1], c.cx_px = b.k[2], c.cy_px = b.k[3];
  c.k1 = b.k[4], c.k2 = b.k[5], c.p1 = b.k[6], c.p2 = b.k[7], c.k3 = b.k[8];
  result->projector.f_px = b.proj[0];
  result->projector.c_px = b.proj[1];
  result->projector.camera_from_projector = FromAngleAxis(b.proj_r, b.proj_t);
  result->projector.mirror_cubic_cols = b.proj[2];
  result->projector.sheet_smile_cols = b.proj[3];
  result->projector.columns = p0.columns;
  result->projector.fan_half_angle_deg = p0.fan_half_angle_deg;
  for (const auto& board : b.boards)
    result->camera_from_board.push_back(FromAngleAxis(board.data(), board.data() + 3));
}

// RMS of the corners [px] and the stripe points [columns], in the residuals' own units.
void ResidualRms(ceres::Problem* problem, ProbeCalibResult* result) {
  double corner_ss = 0, stripe_ss = 0;
  std::vector<double> residuals;
  ceres::Problem::EvaluateOptions eo;
  problem->Evaluate(eo, nullptr, &residuals, nullptr, nullptr);
  const size_t nc = 2 * static_cast<size_t>(result->corners_used);
  for (size_t i = 0; i < residuals.size(); ++i) {
    const double r = residuals[i];
    (i < nc ? corner_ss : stripe_ss) += r * r;
  }
  result->corner_rms_px = std::sqrt(corner_ss / static_cast<double>(nc)) * kCornerSigmaPx;
  result->stripe_rms_columns = std::sqrt(stripe_ss / result->stripes_used) * kStripeSigmaColumns;
}

}  // namespace

double ProjectorParams::ColumnOf(const Vec3& p) const {
  const Vec3 q = camera_from_projector.inverse() * p;
  return c_px + f_px * q.x() / q.z();
}

probe_fw::ProbeModel CalibratedProbeModel(const probe_fw::ProbeModel& design,
                                          const ProbeCalibResult& r,
                                          const std::string& calibration_id) {
  probe_fw::ProbeModel m = design;
  m.calibration_id = calibration_id;
  const Intrinsics& c = r.camera;
  m.camera.fx_px = c.fx_px, m.camera.fy_px = c.fy_px, m.camera.cx_px = c.cx_px;
  m.camera.cy_px = c.cy_px, m.camera.k1 = c.k1, m.camera.k2 = c.k2, m.camera.p1 = c.p1;
  m.camera.p2 = c.p2, m.camera.k3 = c.k3;
  m.projector.f_px = r.projector.f_px;
  m.projector.c_px = r.projector.c_px;
  m.projector.camera_from_projector = r.projector.camera_from_projector;
  m.projector.mirror_cubic_cols = r.projector.mirror_cubic_cols;
  m.projector.sheet_smile_cols = r.projector.sheet_smile_cols;
  m.calibration_stats = {true,           r.views_used,    r.corners_used,
                         r.stripes_used, r.corner_rms_px, r.stripe_rms_columns};
  m.Validate();
  return m;
}

bool InsideTheCorners(const std::vector<Vec2>& corners,
                      const ChessboardSpec& board,
                      double x_px,
                      double y_px) {
  if (corners.empty()) return false;
  const std::size_t cols = static_cast<std::size_t>(board.inner_cols);
  const std::size_t rows = static_cast<std::size_t>(board.inner_rows);
  // The outer inner corners in order around the board; the image of a plane's convex
  // quadrilateral is convex (a perspective map keeps lines), so the point is inside when it is
  // on the same side of all four edges.
  const Vec2 quad[4] = {corners[0], corners[cols - 1], corners[rows * cols - 1],
                        corners[(rows - 1) * cols]};
  const Vec2 p(x_px, y_px);
  int sign = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec2 a = quad[k], b = quad[(k + 1) % 4];
    const double cross = (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
    const int side = cross > 0 ? 1 : -1;
    if (sign != 0 && side != sign) return false;
    sign = side;
  }
  return true;
}

bool OnUniformLight(const GrayImage& led, double x_px, int y_px) {
  const int x = static_cast<int>(std::lround(x_px));
  if (x - kUniformHalfPx < 0 || x + kUniformHalfPx >= led.width || y_px < 0 || y_px >= led.height)
    return false;
  int lo = 1 << 16, hi = 0;
  for (int dx = -kUniformHalfPx; dx <= kUniformHalfPx; ++dx) {
    const int v = led.pixels[static_cast<std::size_t>(y_px) * static_cast<std::size_t>(led.width) +
                             static_cast<std::size_t>(x + dx)];
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  return hi > ((1 << led.bit_depth) - 1) / 4 && lo >= kUniformRatio * hi;
}

ProbeCalibReport CalibrateProbe(const std::vector<GrayImage>& leds,
                                const std::vector<StripeObservation>& stripes,
                                const ChessboardSpec& board,
                                const probe_fw::ProbeModel& design,
                                const std::function<void(const std::string&)>& progress) {
  const auto say = [&](const std::string& line) {
    if (progress) progress(line);
  };
  ProbeCalibReport report;
  say("camera start: OpenCV calibrateCamera on " + std::to_string(leds.size()) + " LED frames");
  report.camera_start = CalibrateCamera(leds, board);
  ProbeCalibInput in;
  in.board = board;
  in.corners = DetectCorners(leds, board);
  std::vector<StripeObservation> usable;
  for (const StripeObservation& s : stripes) {
    if (s.view < 0 || static_cast<std::size_t>(s.view) >= leds.size())
      throw CameraCalibError("a stripe point names view " + std::to_string(s.view) + " of " +
                             std::to_string(leds.size()));
    const auto v = static_cast<std::size_t>(s.view);
    if (OnUniformLight(leds[v], s.x_px, static_cast<int>(std::lround(s.y_px))) &&
        InsideTheCorners(in.corners[v], board, s.x_px, s.y_px))
      usable.push_back(s);
  }
  report.stripes_found = stripes.size();
  report.stripes_on_light = usable.size();
  report.stripe_stride =
      static_cast<int>((usable.size() + kMaxStripePoints - 1) / kMaxStripePoints);
  for (std::size_t k = 0; k < usable.size(); k += std::max(1, report.stripe_stride))
    in.stripes.push_back(usable[k]);
  in.camera_start = report.camera_start.intrinsics;
  const probe_fw::ProjectorModel& p = design.projector;
  in.projector_start = {p.f_px,
                        p.c_px,
                        p.camera_from_projector,
                        p.mirror_cubic_cols,
                        p.sheet_smile_cols,
                        p.columns,
                        p.fan_half_angle_deg};
  in.camera_from_board_start.assign(leds.size(), Pose3::Identity());
  const auto& cam = report.camera_start;
  for (std::size_t k = 0; k < cam.views_used.size(); ++k)
    in.camera_from_board_start[static_cast<std::size_t>(cam.views_used[k])] =
        cam.camera_from_board[k];
  say("joint adjustment: camera, projector and " + std::to_string(cam.views_used.size()) +
      " board poses from " + std::to_string(in.stripes.size()) + " stripe points");
  report.result = AdjustCameraAndProjector(in);
  return report;
}

ProbeCalibResult AdjustCameraAndProjector(const ProbeCalibInput& in) {
  if (in.camera_from_board_start.size() != in.corners.size())
    throw CameraCalibError("one start pose per view is needed");
  const bool curved = in.projector_start.columns > 0;
  JointBlocks b = StartBlocks(in);
  ceres::Problem problem;
  ProbeCalibResult result;
  AddCorners(in, &b, &problem, &result);
  AddStripes(in, &b, &problem, &result);
  // Every light plane contains the projector's y axis (the direction along the stripe), so
  // moving the projector along it changes no plane: a gauge freedom the solver would wander in
  // (it drifted 111 mm on the reference probe). Its camera-frame y (~ that axis: the projector
  // is turned about y) is held at the start value.
  problem.SetManifold(b.proj_t, new ceres::SubsetManifold(3, {1}));
  // Without the mirror's range the cubic has no scale: the design's flat sheet, linear mirror.
  if (!curved) problem.SetManifold(b.proj, new ceres::SubsetManifold(4, {2, 3}));
  Solve(&problem, &result);
  if (curved) CheckSheetTerms(in, b.proj, &problem, &result);
  ReadBack(b, in.projector_start, &result);
  ResidualRms(&problem, &result);
  return result;
}

}  // namespace mlp::calib
