#include "common.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace mlp::geometry::internal {

void OrthonormalBasis(const Vec3& axis, Vec3* u, Vec3* v) {
  const Vec3 w = axis.normalized();
  // Cross with the coordinate axis least aligned with w: never near-parallel.
  Eigen::Index k = 0;
  w.cwiseAbs().minCoeff(&k);
  *u = Vec3::Unit(k).cross(w).normalized();
  *v = w.cross(*u);
}

Points3 ToFrame(
    const Points3& points, const Vec3& origin, const Vec3& u, const Vec3& v, const Vec3& w) {
  Mat3 r;
  r.row(0) = u.transpose();
  r.row(1) = v.transpose();
  r.row(2) = w.transpose();
  return r * (points.colwise() - origin);
}

Covariance TwoStageCovariance(const FitResult<Plane>& plane,
                              const Covariance& in_plane,
                              const std::vector<std::string>& renamed_first) {
  Covariance cov;
  cov.parameters = plane.covariance.parameters;
  for (size_t k = 0; k < in_plane.parameters.size(); ++k) {
    cov.parameters.push_back(k < renamed_first.size() ? renamed_first[k] : in_plane.parameters[k]);
  }
  const Eigen::Index p = plane.covariance.matrix.rows(), q = in_plane.matrix.rows();
  cov.matrix = Eigen::MatrixXd::Zero(p + q, p + q);
  cov.matrix.topLeftCorner(p, p) = plane.covariance.matrix;
  cov.matrix.bottomRightCorner(q, q) = in_plane.matrix;
  cov.u = plane.covariance.u;
  cov.v = plane.covariance.v;
  return cov;
}

void ThrowDegenerate(const std::string& shape, const std::string& why) {
  throw GeometryError(ErrorCode::kDegenerate,
                      shape + ": the points do not determine it (" + why + ")");
}

void ThrowNotSeparable(const std::string& shape, bool judged) {
  if (!judged) ThrowDegenerate(shape, "parameters not separable");
  throw GeometryError(ErrorCode::kDegenerate,
                      shape +
                          ": not determined: parameters not separable, their standard "
                          "deviation unbounded");
}

double CoveredAngleDeg(std::vector<double>& angles_rad) {
  if (angles_rad.empty()) return 0.0;
  for (double& a : angles_rad) a = std::remainder(a, 2 * M_PI);
  std::sort(angles_rad.begin(), angles_rad.end());
  double gap = angles_rad.front() + 2 * M_PI - angles_rad.back();
  for (size_t k = 1; k < angles_rad.size(); ++k)
    gap = std::max(gap, angles_rad[k] - angles_rad[k - 1]);
  return (2 * M_PI - gap) * 180.0 / M_PI;
}

void RequireCoverage(const std::string& shape,
                     double covered_deg,
                     double min_deg,
                     const std::string& about,
                     const std::string& why) {
  if (covered_deg >= min_deg) return;
  std::ostringstream text;
  text.precision(3);
  text << shape << ": not determined: the points cover " << covered_deg << " deg about the fitted "
       << about << "; below " << min_deg << " deg " << why;
  throw GeometryError(ErrorCode::kDegenerate, text.str());
}

void RequireDetermined(const std::string& shape,
                       const Covariance& c,
                       const std::vector<std::string>& parameters,
                       double radius,
                       double max_relative) {
  const double limit = max_relative * radius;
  for (const std::string& name : parameters) {
    const double sd = c.StdDev(name);
    if (sd <= limit) continue;  // a missing parameter (-1) is no evidence either way
    std::ostringstream why;
    why.precision(3);
    why << "not determined: the standard deviation of its " << name << " is " << sd << " mm, over "
        << 100.0 * max_relative << " % of its radius " << radius
        << " mm (too short a window for the noise; more points or a wider view)";
    throw GeometryError(ErrorCode::kDegenerate, shape + ": " + why.str());
  }
}

void ThrowNotConverged(const std::string& shape, int iterations) {
  throw GeometryError(ErrorCode::kNotConverged,
                      shape + ": the least-squares solver found no stationary point in " +
                          std::to_string(iterations) + " iterations");
}

}  // namespace mlp::geometry::internal
