#pragma once
// Algebraic (linear) fits used only as starting points for the geometric fits.

#include "mlp/geometry/types.h"

namespace mlp::geometry::internal {

/// Kasa's circle: minimises sum (|q|^2 + D.q + F)^2 over q = p - origin (pass the centroid:
/// the sums then keep their precision far from the origin); `center` is relative to `origin`.
/// Returns false for collinear points.
bool KasaCircle(const Points2& points, const Vec2& origin, Vec2* center, double* radius);
/// Kasa's circle of 3D points projected on the fly to in-plane coordinates basis * (p - origin);
/// `center` is in those coordinates.
bool KasaCircleInPlane(const Points3& points,
                       const Eigen::Matrix<double, 2, 3>& basis,
                       const Vec3& origin,
                       Vec2* center,
                       double* radius);
/// Kasa's sphere, as KasaCircle in 3D. Returns false for coplanar points.
bool KasaSphere(const Points3& points, const Vec3& origin, Vec3* center, double* radius);

/// Symmetric 3x3 part A of the algebraic quadric x^T A x + b^T x + c = 0 through the points
/// (smallest right singular vector of the 10-column design matrix). For a cylinder A is
/// proportional to I - a a^T, for a cone to I - (1 + tan^2 psi) a a^T: the axis is the
/// eigenvector whose eigenvalue stands apart.
Mat3 AlgebraicQuadric(const Points3& centred);

}  // namespace mlp::geometry::internal
