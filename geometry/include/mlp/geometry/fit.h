#pragma once
/// @file Orthogonal-distance least-squares fits (Gaussian fits in the sense of ISO 10360-6).
///
/// Every function centres the data on its centroid before solving, so data far from the origin
/// (1000 mm and more) loses no precision. Closed-form fits (line, plane) use the eigenvectors of
/// the scatter matrix; the others run Levenberg-Marquardt on the exact orthogonal distance with
/// analytic Jacobians in a locally minimal parametrisation (Forbes, NPL DITC 140/89; Shakarji,
/// J. Res. NIST 103 (1998) 633), and stop at a stationary point of the sum of squares.
///
/// Errors: GeometryError (kTooFewPoints, kNonFinite, kDegenerate: the points do not determine
/// the shape, exactly (collinear points) or to FitOptions::max_relative_std_dev of its radius;
/// kNotConverged unless FitOptions::require_convergence is off: then stats.converged says).
/// Results are always finite, with the covariance of their parameters.

#include "mlp/geometry/distance.h"
#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <optional>

namespace mlp::geometry {

/// What "the least-squares circle" of points in space means. The two agree on coplanar points;
/// on points that are not coplanar they differ, on test sets by far more than TraCIM's 0.1 urad
/// limit (tests/geometry/circle3_test.cc).
enum class Circle3Definition {
  /// ISO 10360-6 (as PTB's TraCIM Gaussian test): minimises the sum of squared orthogonal
  /// distances in space, d^2 = h^2 + (rho - r)^2 (h: height over the circle's plane, rho:
  /// distance from its axis). The default for a feature measured in 3D.
  kSpatial,
  /// NIST ATEP-CMS (its Circle3d reference pairs): the least-squares plane first, then the
  /// least-squares circle of the points projected on it.
  kPlaneThenCircle,
};

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
  /// FitCircle3 (and FitCircle3Robust) only.
  Circle3Definition circle3 = Circle3Definition::kSpatial;
  /// "Not determined" as the data show it (issue 49): a circle, sphere, cylinder, cone or
  /// ellipse whose reported standard deviation of its radius (semi-axes, the cone's distance)
  /// or of any coordinate of its centre or axis point exceeds this share of its radius is
  /// refused, GeometryError(kDegenerate) naming that standard deviation. Beyond about a tenth
  /// the linearised uncertainty no longer describes the estimate's spread (the model is not
  /// linear over it); well below that a short arc is a measurement, with its sigma. Never
  /// decided from a solver's difficulty. Infinity turns the test off: the least-squares
  /// solution however poorly the data determine it, as a reference computation must give it
  /// (ISO 10360-6 test sets, TraCIM, NIST: 7 points on a 10 deg arc with 3 % form error).
  double max_relative_std_dev = 0.05;
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
/// Circle in space (>= 3 points), by `options.circle3`:
/// - kSpatial (default): residual = signed 3D distance to the circle, sign of rho - r (outside
///   positive); covariance in (center_u, center_v, center_w, tilt_u, tilt_v, radius), with
///   sigma^2 from the 2n residuals h and rho - r whose squares sum to the squared distances.
/// - kPlaneThenCircle: residual = in-plane radial distance; covariance of the plane, then of
///   the in-plane circle.
FitResult<Circle3> FitCircle3(const Points3& points, const FitOptions& options = {});
FitResult<Sphere> FitSphere(const Points3& points, const FitOptions& options = {});
/// The centre of a sphere of known radius (a calibrated reference sphere) through the points:
/// Gauss-Newton on the centre alone from `start`, at most 50 steps, until a step is under 1 nm.
/// On a cap seen from one side a free fit's radius trades against the centre's height; holding
/// the radius removes that. `start` must be on the side of the points the centre is on.
Vec3 SphereCentreWithRadius(const Points3& points, double radius, const Vec3& start);
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
