// Closed-form orthogonal least-squares line and plane: centroid plus eigenvectors of the
// scatter matrix (Pearson 1901; ISO 10360-6 reference solutions for these shapes).

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <vector>

#include "common.h"

namespace mlp::geometry {
namespace {

using internal::ComputeMoments;
using internal::ThrowDegenerate;

// Points that all coincide (to rounding) determine neither a line nor a plane.
template <int N>
void CheckNotCoincident(const internal::Moments<N>& m, Eigen::Index n, const char* shape) {
  const double spread = std::sqrt(m.scatter.trace() / static_cast<double>(n));
  if (!(spread > 1e-12 * (1.0 + m.centroid.norm()))) ThrowDegenerate(shape, "all points coincide");
}

}  // namespace

void FitOptions::Check() const {
  if (max_iterations < 1 || max_iterations > 100000) {
    throw GeometryError(ErrorCode::kInvalidArgument, "FitOptions.max_iterations must be 1..100000");
  }
  if (circle3 != Circle3Definition::kSpatial && circle3 != Circle3Definition::kPlaneThenCircle)
    throw GeometryError(ErrorCode::kInvalidArgument, "FitOptions.circle3 is not a definition");
  if (!(max_relative_std_dev > 0.0))  // NaN fails too; infinity is "off"
    throw GeometryError(ErrorCode::kInvalidArgument,
                        "FitOptions.max_relative_std_dev must be above 0 (infinity: off)");
}

double Covariance::StdDev(const std::string& name) const {
  for (size_t i = 0; i < parameters.size(); ++i) {
    if (parameters[i] == name) return std::sqrt(std::max(0.0, matrix(i, i)));
  }
  return -1.0;
}

FitResult<Line2> FitLine2(const Points2& points) {
  internal::CheckPoints(points, 2, "line", false);
  const auto m = ComputeMoments<2>(points);
  CheckNotCoincident(m, points.cols(), "line");
  const auto es = internal::SortedEigen<2>(m.scatter);
  const Eigen::Vector2d ev = es.eigenvalues().cwiseMax(0.0);
  if (ev(1) - ev(0) <= 1e-9 * ev(1)) ThrowDegenerate("line", "no dominant direction");
  FitResult<Line2> fit;
  fit.shape.point = m.centroid;
  fit.shape.direction = internal::CanonicalSign<Vec2>(es.eigenvectors().col(1));
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return SignedDistance(fit.shape, points.col(i)); }, 0);
  const double n = static_cast<double>(points.cols());
  const double sigma2 = points.cols() > 2 ? ev(0) / (n - 2.0) : 0.0;
  fit.covariance.parameters = {"offset", "angle"};
  fit.covariance.matrix = Eigen::Vector2d(sigma2 / n, sigma2 / ev(1)).asDiagonal();
  return fit;
}

FitResult<Line3> FitLine3(const Points3& points) {
  internal::CheckPoints(points, 2, "line", false);
  const auto m = ComputeMoments<3>(points);
  CheckNotCoincident(m, points.cols(), "line");
  const auto es = internal::SortedEigen<3>(m.scatter);
  const Vec3 ev = es.eigenvalues().cwiseMax(0.0);
  if (ev(2) - ev(1) <= 1e-9 * ev(2)) ThrowDegenerate("line", "no dominant direction");
  FitResult<Line3> fit;
  fit.shape.point = m.centroid;
  fit.shape.direction = internal::CanonicalSign<Vec3>(es.eigenvectors().col(2));
  // Distance to the line from its two across-components (vectorised).
  Eigen::Matrix<double, 2, 3> across;
  across.row(0) = es.eigenvectors().col(1).transpose();
  across.row(1) = es.eigenvectors().col(0).transpose();
  const Eigen::Matrix2Xd q = (across * points).colwise() - across * m.centroid;
  fit.stats = internal::StatsOf(q.colwise().norm().transpose(), 0);
  // Two residual components per point (across u and v), four parameters.
  const double n = static_cast<double>(points.cols());
  const double sigma2 = points.cols() > 2 ? (ev(0) + ev(1)) / (2.0 * n - 4.0) : 0.0;
  auto& cov = fit.covariance;
  cov.parameters = {"offset_u", "offset_v", "tilt_u", "tilt_v"};
  cov.matrix = Eigen::Vector4d(sigma2 / n, sigma2 / n, sigma2 / ev(2), sigma2 / ev(2)).asDiagonal();
  cov.u = es.eigenvectors().col(1);
  cov.v = fit.shape.direction.cross(cov.u);
  return fit;
}

namespace internal {

FitResult<Plane> PlaneFromMoments(const Moments<3>& m, Eigen::Index count) {
  CheckNotCoincident(m, count, "plane");
  const auto es = SortedEigen<3>(m.scatter);
  const Vec3 ev = es.eigenvalues().cwiseMax(0.0);
  // Collinear points: the second extent is below 1e-7 of the first.
  if (ev(1) <= 1e-14 * ev(2)) ThrowDegenerate("plane", "the points are collinear");
  if (ev(1) - ev(0) <= 1e-9 * ev(1)) ThrowDegenerate("plane", "no dominant plane");
  FitResult<Plane> fit;
  fit.shape.point = m.centroid;
  fit.shape.normal = CanonicalSign<Vec3>(es.eigenvectors().col(0));
  const double n = static_cast<double>(count);
  const double sigma2 = count > 3 ? ev(0) / (n - 3.0) : 0.0;
  auto& cov = fit.covariance;
  cov.parameters = {"offset", "tilt_u", "tilt_v"};
  cov.matrix = Vec3(sigma2 / n, sigma2 / ev(2), sigma2 / ev(1)).asDiagonal();
  cov.u = es.eigenvectors().col(2);
  cov.v = fit.shape.normal.cross(cov.u);
  return fit;
}

Points2 ProjectOnPlane(const Points3& points, const FitResult<Plane>& plane) {
  Eigen::Matrix<double, 2, 3> uv;
  uv.row(0) = plane.covariance.u.transpose();
  uv.row(1) = plane.covariance.v.transpose();
  Points2 q = uv * points;
  q.colwise() -= uv * plane.shape.point;
  return q;
}

}  // namespace internal

namespace {

// Points per block of the one-pass plane fit: 1024 points (24 KB) per residual bound.
constexpr Eigen::Index kPlaneBlock = 1024;

// A normal close to the final one, from an evenly strided subsample (a few microseconds); any
// unit vector would keep FitPlane exact, a close one only makes its second look cheap.
Vec3 TrialNormal(const Points3& points) {
  const Points3 sample = internal::Subsample<3>(points, 512);
  const Vec3 shift = sample.col(0);
  const auto sums = internal::SumShiftedPoints(sample.data(), sample.cols(), shift.data());
  if (!std::isfinite(sums.outer[0] + sums.outer[3] + sums.outer[5])) return Vec3::UnitZ();
  const Vec3 n =
      internal::SortedEigen<3>(internal::MomentsFromSums(shift, sums, sample.cols()).scatter)
          .eigenvectors()
          .col(0);
  return n.allFinite() ? n : Vec3::UnitZ();
}

double MaxR0(const internal::BlockBounds& b, double sign) {
  return sign > 0.0 ? b.max_r0 : -b.min_r0;
}
double MinR0(const internal::BlockBounds& b, double sign) {
  return sign > 0.0 ? b.min_r0 : -b.max_r0;
}

// Exact extremes of the residual normal . (p - shift) - offset over the points of the blocks
// that may hold them. The trial normal n0 has an arbitrary sign: `sign` aligns it with the
// normal (with sign -1 the trial residual bounds swap). For a point q (shifted by `shift`) of
// block b, normal . q differs from the trial residual by at most |normal - sign n0| |q|
// (Cauchy-Schwarz), so only blocks whose widened trial interval reaches the best guaranteed
// extreme can hold the true one.
void ResidualExtremes(const Points3& points,
                      const std::vector<internal::BlockBounds>& bounds,
                      const Vec3& shift,
                      const Vec3& trial,
                      double sign,
                      const Vec3& normal,
                      double offset,
                      FitStats* stats) {
  const double tilt = (normal - sign * trial).norm();
  std::vector<double> slack(bounds.size());
  double max_floor = -INFINITY, min_ceiling = INFINITY;
  for (size_t b = 0; b < bounds.size(); ++b) {
    const double q = std::sqrt(bounds[b].max_q2);
    // Rounding of n0 . q and of |q| adds at most a few ulps of |q|: widened by 1e-12 |q|.
    slack[b] = tilt * q * (1.0 + 1e-12) + 1e-12 * q;
    max_floor = std::max(max_floor, MaxR0(bounds[b], sign) - slack[b]);
    min_ceiling = std::min(min_ceiling, MinR0(bounds[b], sign) + slack[b]);
  }
  stats->min_residual = INFINITY;
  stats->max_residual = -INFINITY;
  for (size_t b = 0; b < bounds.size(); ++b) {
    const bool may_hold_max = MaxR0(bounds[b], sign) + slack[b] >= max_floor;
    const bool may_hold_min = MinR0(bounds[b], sign) - slack[b] <= min_ceiling;
    if (!may_hold_max && !may_hold_min) continue;
    const Eigen::Index begin = static_cast<Eigen::Index>(b) * kPlaneBlock;
    const Eigen::Index end = std::min(points.cols(), begin + kPlaneBlock);
    for (Eigen::Index i = begin; i < end; ++i) {
      const double r = normal.dot(points.col(i) - shift) - offset;
      stats->min_residual = std::min(stats->min_residual, r);
      stats->max_residual = std::max(stats->max_residual, r);
    }
  }
}

// Sum of squared residuals r = a . q - off of the final plane, from sums taken relative to
// the trial plane in the same pass: with t the trial normal (sign-aligned) and d = a - t,
// r = t . q - off + d . q. Every term is of the size of the residuals or of the tilt d, so the
// rounding is ~1e-16 of the squared residuals, not of the squared extent of the data (as
// lambda_min of the scatter matrix would be: ~10 pm RMS for three points that fit exactly).
double SumOfSquares(const internal::PlaneSums& s,
                    double sign,
                    const Vec3& trial,
                    const Vec3& normal,
                    double off,
                    Eigen::Index count) {
  const double n = static_cast<double>(count);
  const Vec3 d = normal - sign * trial;
  const Vec3 sum_q(s.points.sum[0], s.points.sum[1], s.points.sum[2]);
  const Vec3 sum_r0q = sign * Vec3(s.trial.r0q[0], s.trial.r0q[1], s.trial.r0q[2]);
  const auto& o = s.points.outer;
  Mat3 outer;
  outer << o[0], o[1], o[2], o[1], o[3], o[4], o[2], o[4], o[5];
  const double trial_part = s.trial.r0r0 - 2.0 * off * sign * s.trial.r0 + n * off * off;
  const double cross = 2.0 * d.dot(sum_r0q - off * sum_q);
  return std::max(0.0, trial_part + cross + d.dot(outer * d));
}

}  // namespace

// Large clouds: one pass over the points gives the moments and, per block of points, the
// extremes of a trial residual, from which the exact residual extremes need a second look at a
// few blocks only (ResidualExtremes); the sum of squares comes from the same pass
// (SumOfSquares). Small clouds, in cache anyway, take the direct two passes.
FitResult<Plane> FitPlane(const Points3& points) {
  internal::CheckPoints(points, 3, "plane", false);
  if (points.cols() <= 4 * kPlaneBlock) {
    const auto m = ComputeMoments<3>(points);
    FitResult<Plane> fit = internal::PlaneFromMoments(m, points.cols());
    const Vec3 normal = fit.shape.normal, centroid = m.centroid;
    fit.stats = internal::ComputeStats(
        points.cols(), [&](Eigen::Index i) { return normal.dot(points.col(i) - centroid); }, 0);
    return fit;
  }
  const Vec3 trial = TrialNormal(points);
  const Vec3 shift = points.col(0);
  std::vector<internal::BlockBounds> bounds(
      static_cast<size_t>((points.cols() + kPlaneBlock - 1) / kPlaneBlock));
  const auto sums = internal::SumShiftedPointsWithBounds(points.data(), points.cols(), shift.data(),
                                                         trial.data(), kPlaneBlock, bounds.data());
  const auto m = internal::MomentsFromSums(shift, sums.points, points.cols());
  FitResult<Plane> fit = internal::PlaneFromMoments(m, points.cols());
  const Vec3 normal = fit.shape.normal;
  const double sign = normal.dot(trial) < 0.0 ? -1.0 : 1.0;
  const double off = normal.dot(m.centroid - shift);
  fit.stats.n = static_cast<int>(points.cols());
  fit.stats.iterations = 0;
  fit.stats.rms = std::sqrt(SumOfSquares(sums, sign, trial, normal, off, points.cols()) /
                            static_cast<double>(points.cols()));
  ResidualExtremes(points, bounds, shift, trial, sign, normal, off, &fit.stats);
  return fit;
}

}  // namespace mlp::geometry
