#pragma once
/// @file Chebyshev (minimum-zone) fits and the functional sizes of bores and bosses.
///
/// Minimum zone (ISO 1101 form tolerances; ISO 12781 flatness, ISO 12780 straightness,
/// ISO 12181 roundness): the narrowest zone between two parallel lines/planes or two concentric
/// circles containing all points. Maximum-inscribed circle (the largest pin that fits a bore)
/// and minimum-circumscribed circle (the smallest ring over a boss) give functional sizes
/// (ISO 14405-1 GX/GN). Circles in 3D are solved in the least-squares plane of the points.
/// Sphericity and cylindricity: two concentric spheres / coaxial cylinders (ISO 12180).
///
/// Errors: GeometryError (kTooFewPoints, kNonFinite, kDegenerate, kUnbounded; kNotConverged
/// when an LP has no solution): no answer. A zone that is a valid zone but not shown minimal
/// (the iterations ran out, or the least-squares start did not converge) is returned with
/// stats.converged = false: an expected numerical outcome is a result (docs/DEVELOPING.md).

#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <optional>

namespace mlp::geometry {

/// Minimum-zone straightness of a profile in the least-squares plane of its points.
struct MinZoneLineFit {
  Line3 line;                 ///< mid-line of the zone
  Vec3 plane_normal;          ///< normal of the profile plane
  double straightness = 0.0;  ///< zone width [mm]
  FitStats stats;             ///< residuals to the mid-line, signed in the profile plane
};

/// Minimum-zone flatness.
struct MinZonePlaneFit {
  Plane plane;            ///< mid-plane of the zone
  double flatness = 0.0;  ///< zone width [mm]
  FitStats stats;
};

/// Minimum-zone roundness: two concentric circles with the smallest radial separation.
struct MinZoneCircleFit {
  Circle3 circle;             ///< centre of the zone, radius = mean of inner and outer
  double roundness = 0.0;     ///< outer - inner radius [mm]
  double inner_radius = 0.0;  ///< [mm]
  double outer_radius = 0.0;  ///< [mm]
  FitStats stats;
};

/// Minimum-zone sphericity: two concentric spheres with the smallest radial separation.
struct MinZoneSphereFit {
  Sphere sphere;              ///< centre of the zone, radius = mean of inner and outer
  double sphericity = 0.0;    ///< outer - inner radius [mm]
  double inner_radius = 0.0;  ///< [mm]
  double outer_radius = 0.0;  ///< [mm]
  FitStats stats;             ///< residuals to `sphere`
};

/// Minimum-zone cylindricity: two coaxial cylinders with the smallest radial separation.
struct MinZoneCylinderFit {
  Cylinder cylinder;          ///< axis of the zone (point at the foot of the centroid), mean radius
  double cylindricity = 0.0;  ///< outer - inner radius [mm]
  double inner_radius = 0.0;  ///< [mm]
  double outer_radius = 0.0;  ///< [mm]
  FitStats stats;             ///< residuals to `cylinder`
};

/// Minimum-zone straightness of a profile in the plane.
struct MinZoneLine2Fit {
  Line2 line;                 ///< mid-line of the zone
  double straightness = 0.0;  ///< zone width [mm]
  FitStats stats;             ///< residuals along the line's left normal
};

/// Minimum-zone roundness in the plane.
struct MinZoneCircle2Fit {
  Circle2 circle;             ///< centre of the zone, radius = mean of inner and outer
  double roundness = 0.0;     ///< outer - inner radius [mm]
  double inner_radius = 0.0;  ///< [mm]
  double outer_radius = 0.0;  ///< [mm]
  FitStats stats;
};

/// Circle with functional size (MIC or MCC); stats are residuals to that circle.
struct FunctionalCircleFit {
  Circle3 circle;
  FitStats stats;
};

struct ZoneOptions {
  /// Outer iterations: sequential-LP steps for the circles (minimum zone, maximum inscribed),
  /// re-alignment passes for lines and planes (at most 8). Running out is not an error: the
  /// zone found so far, with stats.converged = false.
  int max_iterations = 200;
  void Check() const;
};

MinZoneLineFit FitMinZoneLine(const Points3& points, const ZoneOptions& options = {});
MinZonePlaneFit FitMinZonePlane(const Points3& points, const ZoneOptions& options = {});
MinZoneCircleFit FitMinZoneCircle(const Points3& points, const ZoneOptions& options = {});
/// Sphericity (ISO 1101; >= 5 points, not coplanar), from the least-squares sphere.
MinZoneSphereFit FitMinZoneSphere(const Points3& points, const ZoneOptions& options = {});
/// Cylindricity (ISO 12180; >= 7 points), from the least-squares cylinder (whose search for a
/// starting axis `initial` skips, as in FitCylinder). Points that do not determine an axis
/// (on one circle) throw kDegenerate there.
MinZoneCylinderFit FitMinZoneCylinder(const Points3& points,
                                      const ZoneOptions& options = {},
                                      const std::optional<Cylinder>& initial = std::nullopt);
MinZoneLine2Fit FitMinZoneLine2(const Points2& points, const ZoneOptions& options = {});
MinZoneCircle2Fit FitMinZoneCircle2(const Points2& points, const ZoneOptions& options = {});
/// Largest circle with no point inside (a bore's functional size). Throws kUnbounded when the
/// points do not surround a centre (an arc under 180 deg).
FunctionalCircleFit FitMaxInscribedCircle(const Points3& points, const ZoneOptions& options = {});
/// Smallest circle containing every point (a boss's functional size). Exact (Welzl 1991).
FunctionalCircleFit FitMinCircumscribedCircle(const Points3& points);

}  // namespace mlp::geometry
