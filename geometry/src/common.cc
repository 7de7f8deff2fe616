#include "common.h"

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

void ThrowNotConverged(const std::string& shape, int iterations) {
  throw GeometryError(ErrorCode::kNotConverged,
                      shape + ": the least-squares solver found no stationary point in " +
                          std::to_string(iterations) + " iterations");
}

}  // namespace mlp::geometry::internal
