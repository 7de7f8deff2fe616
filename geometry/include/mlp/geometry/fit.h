#pragma once
/// @file Orthogonal-distance least-squares fits (Gaussian fits in the sense of ISO 10360-6).
///
/// Every function centres the data on its centroid before solving, so data far from the origin
/// (1000 mm and more) loses no precision. Closed-form fits (line, plane) use the eigenvectors of
/// the scatter matrix; the others run Levenberg-Marquardt on the exact orthogonal distance with
/// analytic Jacobians in a locally minimal parametrisation (Forbes, NPL DITC 140/89; Shakarji,
/// J. Res. NIST 103 (1998) 633), and stop at a stationary point of the sum of squares.
///
/// Errors: GeometryError (kTooFewPoints, kNonFinite, kDegenerate, kNotConverged unless
/// FitOptions::require_convergence is off: then stats.converged says). Results are always
/// finite.

#include "mlp/geometry/distance.h"
#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <optional>

namespace mlp::geometry {

/// Options of the iterative fits.
struct FitOptions {
  int max_iterations = 200;
  /// Cylinder and cone without an initial shape: try several candidate axes (principal axes of
  /// the points and of an algebraic quadric) on a subsample and keep the best. Off: only the
  /// quadric's axis is tried.
  bool multi_start = true;
  /// On (the default): reaching max_iterations without a stationary point throws
  /// GeometryError(kNotConverged). Off: the last iterate is returned, when it is a valid shape,
  /// with stats.converged = false, so that the caller weighs it with its other evidence (an
  /// expected numerical outcome is a result, docs/DEVELOPING.md). A state that is not a valid
  /// shape (not finite, radius <= 0) throws either way.
  bool require_convergence = true;
  void Check() const;
};

/// Line through >= 2 points in the plane. Signed residual: distance along the left normal.
FitResult<Line2> FitLine2(const Points2& points);
/// Line through >= 2 points in space; `point` is the centroid. Residuals are distances (>= 0).
FitResult<Line3> FitLine3(const Points3& points);
/// Plane through >= 3 non-collinear points; `point` is the centroid. The normal's largest
/// component is made positive.
FitResult<Plane> FitPlane(const Points3& points);
/// Circle through >= 3 non-collinear points in the plane.
FitResult<Circle2> FitCircle2(const Points2& points, const FitOptions& options = {});
/// Circle in space, ISO/NIST convention: least-squares plane first, then the least-squares
/// circle of the points projected on it. Residual: in-plane radial distance.
FitResult<Circle3> FitCircle3(const Points3& points, const FitOptions& options = {});
FitResult<Sphere> FitSphere(const Points3& points, const FitOptions& options = {});
/// Cylinder (>= 5 points). `initial` skips the search for a starting axis.
FitResult<Cylinder> FitCylinder(const Points3& points,
                                const FitOptions& options = {},
                                const std::optional<Cylinder>& initial = std::nullopt);
/// Cone (>= 6 points) in NIST's parametrisation (see Cone).
FitResult<Cone> FitCone(const Points3& points,
                        const FitOptions& options = {},
                        const std::optional<Cone>& initial = std::nullopt);
/// Ellipse in the plane (>= 5 points), orthogonal distances via exact foot points.
FitResult<Ellipse2> FitEllipse2(const Points2& points, const FitOptions& options = {});
/// Planar ellipse in space: least-squares plane, then the 2D ellipse of the projected points.
FitResult<Ellipse3> FitEllipse3(const Points3& points, const FitOptions& options = {});

}  // namespace mlp::geometry
