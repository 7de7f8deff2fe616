#pragma once
/// @file Features measured from clouds in the machine frame (seed 004 step 5): the points are
/// segmented by the nominal (CAD) geometry, as an inspection plan does, then fitted by least
/// squares; functional sizes where a mating part cares (ISO 14405-1: the largest pin a bore
/// takes).

#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <limits>
#include <stdexcept>
#include <vector>

namespace mlp::features {

/// A measurement that cannot be made from the points given (too few on the feature, an arc too
/// short for a functional size): the reason names what is missing.
class FeatureError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A bore, or with `boss` the outside of a cylindrical boss: the wall from the top face down
/// `depth_mm` along -axis.
struct BoreNominal {
  geometry::Vec3 top_centre_mcs = geometry::Vec3::Zero();  ///< axis point in the top face
  geometry::Vec3 axis_mcs = geometry::Vec3::UnitZ();       ///< unit, out of the bore (up a boss)
  double diameter_mm = 0.0, depth_mm = 0.0;
  bool boss = false;
  /// Points within this radial distance of the nominal wall belong to it.
  double band_mm = 0.5;
  /// Away from the rim and the bottom (their edges are not the wall).
  double edge_margin_mm = 1.0;
  /// Also the minimum-zone cylindricity of the wall (ISO 12180, a Chebyshev fit).
  bool cylindricity = false;
};

struct BoreMeasurement {
  geometry::Vec3 top_centre_mcs = geometry::Vec3::Zero();  ///< fitted axis at the nominal top
  geometry::Vec3 axis_mcs = geometry::Vec3::UnitZ();
  double diameter_mm = 0.0;  ///< least-squares cylinder
  /// Standard uncertainty of diameter_mm from the fit alone (k = 1: twice the radius' standard
  /// deviation from the residuals, geometry Covariance): what the points seen determine, not
  /// the probe's calibration. A short arc of a large bore is a measurement with a large u.
  double diameter_u_mm = 0.0;
  /// The functional size (ISO 14405-1): a bore's maximum inscribed circle (the largest pin it
  /// takes), a boss's minimum circumscribed circle (the smallest ring over it), of the wall
  /// points projected along the fitted axis; 0 when the points span 180 deg or less (no
  /// functional size from under half a circle).
  double functional_diameter_mm = 0.0;
  /// The functional size's Chebyshev fit reached a stationary point (geometry chebyshev.h).
  bool functional_converged = true;
  /// Minimum-zone cylindricity of the wall points [mm]; 0 unless BoreNominal::cylindricity.
  double cylindricity_mm = 0.0;
  /// Its Chebyshev fit reached its zone; true when none asked.
  bool cylindricity_converged = true;
  double rms_mm = 0.0, max_abs_mm = 0.0;
  int points = 0;
  double arc_span_deg = 0.0;  ///< 360 minus the largest angular gap between wall points
  /// The fit reached a stationary point; false: it stopped at its iteration limit and the
  /// values are an estimate (the jobs' gate then refuses to write).
  bool converged = true;
  /// Radial deviation from the fitted cylinder [mm] per degree of angle around the axis (mean of
  /// the points in each 1-degree bin; NaN where none): the roundness profile a report draws.
  /// Angles from the axis' first perpendicular (machine +X for a vertical bore).
  std::vector<double> deviation_by_degree_mm;
};

/// A bore or a boss. Throws FeatureError (fewer than 50 wall points) or geometry::GeometryError
/// (degenerate).
BoreMeasurement MeasureBore(const geometry::Points3& points_mcs, const BoreNominal& nominal);

struct PlaneNominal {
  geometry::Vec3 point_mcs = geometry::Vec3::Zero();
  geometry::Vec3 normal_mcs = geometry::Vec3::UnitZ();
  double band_mm = 0.2;    ///< points this close to the nominal plane belong to it
  double within_mm = 1e9;  ///< and this close to its nominal point (along the plane)
  /// Also the minimum-zone flatness (a Chebyshev fit: ~8 ms for 15,000 points, where the rest
  /// of the face takes well under one; alignments do not need it).
  bool flatness = false;
};

struct PlaneMeasurement {
  geometry::Plane plane;  ///< normal on the nominal's side
  double rms_mm = 0.0;
  int points = 0;   ///< used in the final fit
  int trimmed = 0;  ///< dropped as outliers (chips, burrs, edges)
  /// Where the face is along the nominal normal, at the nominal point: + means proud of the
  /// nominal (material left), - below it [mm].
  double height_mm = 0.0;
  /// Standard uncertainty of height_mm from the fit alone (k = 1; PlaneHeightU at the nominal
  /// point), as BoreMeasurement::diameter_u_mm: what the points seen determine.
  double height_u_mm = 0.0;
  /// The final fit's parameter covariance (offset along the normal at plane.point, tilts
  /// toward covariance.u and .v; geometry fit_result.h): what the features built on this face
  /// take their uncertainty from.
  geometry::Covariance covariance;
  /// Minimum-zone flatness of the points used (ISO 12781), Chebyshev fit [mm]; 0 unless
  /// PlaneNominal::flatness asked for it.
  double flatness_mm = 0.0;
  /// The flatness's minimum-zone fit found its zone (geometry chebyshev.h); true when none asked.
  bool flatness_converged = true;
  /// The area the points cover: 1 mm squares of the plane holding a point [mm^2] (the
  /// plausibility gate's coverage for faces).
  double area_mm2 = 0.0;
  /// The points of the final fit, as indices into the points given (for the report).
  std::vector<Eigen::Index> used;
};

/// Standard uncertainty (k = 1, from the fit's residuals) of the face's height along its normal
/// at `at_mcs`: the offset's variance plus each tilt's times its lever from the centroid
/// squared (GUM 5.1.2, the plane's covariance propagated linearly). Grows with the distance
/// from the points: a face seen in a small window and judged far from it is uncertain there.
double PlaneHeightU(const PlaneMeasurement& face, const geometry::Vec3& at_mcs);

/// Standard uncertainty [rad] of the face's normal turning toward the unit direction `toward`
/// (its component in the plane counts): the tilts' covariance projected on it.
double PlaneTiltU(const PlaneMeasurement& face, const geometry::Vec3& toward);

/// A face: the points in the nominal's band, least squares, then iterated trimming of points
/// beyond 3 RMS (a chip or a burr is not the face) until none is dropped. Linear in the points
/// (15,000 points: well under a millisecond; an MSAC consensus search took 170 ms and is not
/// needed once the nominal has segmented the face). Throws FeatureError (fewer than 50 points).
PlaneMeasurement MeasurePlane(const geometry::Points3& points_mcs, const PlaneNominal& nominal);

}  // namespace mlp::features
