// Closed-form orthogonal least-squares line and plane: centroid plus eigenvectors of the
// scatter matrix (Pearson 1901; ISO 10360-6 reference solutions for these shapes).

#include "mlp/geometry/fit.h"

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

FitResult<Plane> FitPlane(const Points3& points) {
  internal::CheckPoints(points, 3, "plane", false);
  const auto m = ComputeMoments<3>(points);
  FitResult<Plane> fit = internal::PlaneFromMoments(m, points.cols());
  const Vec3 normal = fit.shape.normal;
  const double offset = normal.dot(m.centroid);
  fit.stats = internal::ComputeStats(
      points.cols(), [&](Eigen::Index i) { return normal.dot(points.col(i)) - offset; }, 0);
  return fit;
}

}  // namespace mlp::geometry
