#pragma once
/// @file Features made of several surfaces, as on-machine probing cycles measure them: a web or
/// a slot/pocket width between two opposite faces, a rectangular pocket or boss, a step height,
/// the angle of a face against a datum, a bolt-hole circle (PCD), and an elliptical bore or boss.
/// Each surface is segmented by its nominal and fitted (feature.h); the feature's sizes come
/// from the fits, where the nominal says to evaluate them (ISO 14405-1 two-point sizes are not
/// used: a laser cloud gives whole faces, so a width is the distance between the two fitted
/// faces along the nominal direction at the nominal centre).

#include "mlp/features/feature.h"

#include <vector>

namespace mlp::features {

/// Two opposite faces across `direction_mcs`: a slot or pocket (`inside`: the faces look at each
/// other, air between them) or a web (material between them).
struct WidthNominal {
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();  ///< mid-way between the faces
  geometry::Vec3 direction_mcs = geometry::Vec3::UnitX();
  double width_mm = 0.0;
  bool inside = true;
  double band_mm = 0.2;    ///< points this close to a nominal face belong to it
  double within_mm = 1e9;  ///< and this close to the face's nominal point (keep off corners)
};

struct WidthMeasurement {
  PlaneMeasurement plus, minus;  ///< the faces at +direction and -direction
  double width_mm = 0.0;
  /// Standard uncertainty from the two faces' fits (k = 1): their heights' u in quadrature
  /// (independent points).
  double width_u_mm = 0.0;
  /// The mid-point between the faces on the line through the nominal centre along the nominal
  /// direction.
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();
  double parallelism_deg = 0.0;  ///< angle between the two faces' normals
};

/// Throws FeatureError (a face with too few points, a nominal without width or direction).
WidthMeasurement MeasureWidth(const geometry::Points3& points_mcs, const WidthNominal& nominal);

/// A rectangular pocket (`inside`) or boss: two widths across each other.
struct RectangleNominal {
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();  ///< at the height to measure
  geometry::Vec3 x_direction_mcs = geometry::Vec3::UnitX();
  geometry::Vec3 axis_mcs = geometry::Vec3::UnitZ();  ///< along the walls (the depth axis)
  double size_x_mm = 0.0, size_y_mm = 0.0;
  bool inside = true;
  double band_mm = 0.2;
  /// Each face is measured within this distance of its middle (half the shorter of its length
  /// and the wall's height, less a margin, keeps corner radii and edges out).
  double within_mm = 1e9;
};

struct RectangleMeasurement {
  WidthMeasurement x, y;
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();
  /// Turn of the rectangle about its axis from the nominal, from the four faces' normals [deg].
  double rotation_deg = 0.0;
};

RectangleMeasurement MeasureRectangle(const geometry::Points3& points_mcs,
                                      const RectangleNominal& nominal);

/// The height of face B over face A (B's point along A's normal), e.g. a shoulder or a step.
struct StepNominal {
  PlaneNominal a, b;  ///< both normals out of the material, the same way for a step
};

struct StepMeasurement {
  PlaneMeasurement a, b;
  /// Signed distance from face A's plane to face B at B's nominal point, along A's normal [mm].
  double height_mm = 0.0;
  /// Standard uncertainty from the two faces' fits (k = 1): B's height at its nominal point and
  /// A's plane there (A's tilts over the lever from A's points to B), in quadrature.
  double height_u_mm = 0.0;
  double parallelism_deg = 0.0;
};

StepMeasurement MeasureStep(const geometry::Points3& points_mcs, const StepNominal& nominal);

/// The angle of a face against a datum: another measured face, or a fixed direction (a machine
/// axis) when `datum_face` is false.
struct AngleNominal {
  PlaneNominal face;
  bool datum_face = false;
  PlaneNominal datum;  ///< its normal is the datum direction when datum_face is false
};

struct AngleMeasurement {
  PlaneMeasurement face;
  PlaneMeasurement datum;  ///< empty (points 0) without a datum face
  double angle_deg = 0.0;  ///< between the face's normal and the datum's, 0..180
  /// Standard uncertainty from the fits (k = 1) [deg]: each normal's tilt toward the other, in
  /// quadrature; a fixed datum direction has none.
  double angle_u_deg = 0.0;
  /// The face's turn from its nominal orientation (skew), 0..180 [deg].
  double skew_deg = 0.0;
};

AngleMeasurement MeasureAngle(const geometry::Points3& points_mcs, const AngleNominal& nominal);

/// Holes on a bolt circle: each a bore nominal; the pattern's circle through their centres.
struct PcdNominal {
  std::vector<BoreNominal> holes;  ///< at least 3
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();
  double diameter_mm = 0.0;
};

struct PcdMeasurement {
  std::vector<BoreMeasurement> holes;
  geometry::Vec3 centre_mcs = geometry::Vec3::Zero();  ///< of the circle through the centres
  double diameter_mm = 0.0;
  double diameter_u_mm = 0.0;  ///< from the circle's fit alone (k = 1), as BoreMeasurement's
  double rms_mm = 0.0;         ///< of the centres about that circle
  /// The circle of the centres and every hole's fit reached a stationary point; false: it stopped
  /// at its iteration limit and the values are an estimate (the jobs' gate then refuses to write).
  bool converged = true;
  /// Per hole: true position (ISO 1101: twice the distance from its nominal position, across
  /// the hole's nominal axis) [mm].
  std::vector<double> true_position_mm;
  /// Turn of the pattern about its axis from the nominal, mean over the holes [deg].
  double rotation_deg = 0.0;
};

PcdMeasurement MeasurePcd(const geometry::Points3& points_mcs, const PcdNominal& nominal);

/// An elliptical bore (`inside`) or boss with walls along `axis_mcs`.
struct EllipseNominal {
  geometry::Vec3 top_centre_mcs = geometry::Vec3::Zero();
  geometry::Vec3 axis_mcs = geometry::Vec3::UnitZ();
  geometry::Vec3 major_direction_mcs = geometry::Vec3::UnitX();
  double major_mm = 0.0, minor_mm = 0.0;  ///< diameters
  double depth_mm = 0.0;
  bool inside = true;
  double band_mm = 0.3;
  double edge_margin_mm = 1.0;
};

struct EllipseMeasurement {
  geometry::Vec3 top_centre_mcs = geometry::Vec3::Zero();
  double major_mm = 0.0, minor_mm = 0.0;  ///< diameters
  /// Their standard uncertainties from the fit alone (k = 1: twice the semi-axes' standard
  /// deviations, geometry Covariance).
  double major_u_mm = 0.0, minor_u_mm = 0.0;
  /// Turn of the major axis about the nominal axis from its nominal direction, -90..90 [deg].
  double rotation_deg = 0.0;
  double rms_mm = 0.0, max_abs_mm = 0.0;
  /// The fit reached a stationary point; false: it stopped at its iteration limit and the
  /// values are an estimate (the jobs' gate then refuses to write).
  bool converged = true;
  int points = 0;
};

/// The wall points projected along the nominal axis, then an orthogonal-distance ellipse
/// (geometry::FitEllipse2). The walls must run along the nominal axis (an inclined hole's
/// section is another feature).
EllipseMeasurement MeasureEllipse(const geometry::Points3& points_mcs,
                                  const EllipseNominal& nominal);

}  // namespace mlp::features
