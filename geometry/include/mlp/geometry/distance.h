#pragma once
/// @file Signed orthogonal distance of a point to each primitive [mm]; positive outside / on the
/// side the normal points to. These define the residuals of every fit.

#include "mlp/geometry/types.h"

namespace mlp::geometry {

double SignedDistance(const Line2& line, const Vec2& p);
/// Unsigned distance to a 3D line.
double SignedDistance(const Line3& line, const Vec3& p);
double SignedDistance(const Plane& plane, const Vec3& p);
double SignedDistance(const Circle2& circle, const Vec2& p);
/// Distance in 3D to the circle (a torus of zero tube radius); always >= 0.
double SignedDistance(const Circle3& circle, const Vec3& p);
double SignedDistance(const Sphere& sphere, const Vec3& p);
double SignedDistance(const Cylinder& cylinder, const Vec3& p);
/// NIST cone residual rho cos(psi) - h sin(psi) - s (exact for points not behind the apex).
double SignedDistance(const Cone& cone, const Vec3& p);
/// Exact orthogonal distance to the ellipse (Eberly's bisection for the foot point).
double SignedDistance(const Ellipse2& ellipse, const Vec2& p);
/// Distance in 3D to a planar ellipse: sqrt(in-plane distance^2 + height^2), signed as in-plane.
double SignedDistance(const Ellipse3& ellipse, const Vec3& p);

/// Foot point of `p` on the ellipse x^2/a^2 + y^2/b^2 = 1 (a >= b > 0) in the ellipse's own
/// frame. Eberly, "Distance from a Point to an Ellipse, an Ellipsoid, or a Hyperellipsoid" (2013).
Vec2 EllipseFootPoint(double a, double b, const Vec2& p_in_ellipse);

}  // namespace mlp::geometry
