#pragma once
/// @file A round part gauged from one back-lit image (issue 52: washer-type parts under a
/// telecentric lens, checked against a CMM): the outer contour and the hole's, each a circle
/// fitted as a CMM reports it (least squares over an even sampling round the circle), its
/// smallest and largest diameter, roundness and the two centres' distance (concentricity).
/// Pixels become millimetres through a scale and the back light's edge bias found from master
/// parts with known CMM figures (FitGaugeScale), as a shop sets a gauge with a master.
///
/// The circles are found from the silhouette's sub-pixel crossings of its half grey level along
/// rows and columns (geometry/contour.h, the tool camera's and the grinding cell's edge code),
/// then their edges crossed again along 2,880 normals (as a CMM scans). Dust off the part,
/// burrs and hairs on its edges are left out and counted: points more than 3 px (and 4 robust
/// sigma) off the circle, refitted until none leave; then the kept points are averaged in
/// 0.25 deg sectors round the centre and the circle fitted through the sectors' means, so each
/// direction weighs alike as a CMM's even scan.

#include "mlp/geometry/contour.h"
#include "mlp/geometry/types.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::toolcam {

/// The image shows no part to gauge (no two concentric circles, too few edge points).
class GaugeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One circle of the part [px].
struct GaugedCircle {
  geometry::Vec2 centre_px = geometry::Vec2::Zero();
  double diameter_px = 0.0;                             ///< least squares over the sectors' means
  double min_diameter_px = 0.0, max_diameter_px = 0.0;  ///< twice the sectors' extreme radii
  double roundness_px = 0.0;  ///< largest minus smallest sector radius about the LS centre
  int points = 0;             ///< edge points kept
  int left_out = 0;           ///< edge points near it left out (burrs, hairs, dust)
  int sectors = 0;            ///< of 1440 holding a kept point
  std::vector<geometry::Vec2> sector_means_px;  ///< for a picture
};

struct GaugedPart {
  GaugedCircle outer, inner;
  int stray_points = 0;  ///< edge points on neither circle (dust, the image's border)
};

/// Throws GaugeError when the image shows no ring (two circles of edges round one centre), or
/// either circle over less than 90 % of its turn.
GaugedPart GaugeRing(const geometry::GreyView& image);

/// Pixels to millimetres: d_mm = mm_per_px d_px -/+ 2 edge_bias_mm (the back light makes the
/// material look larger by the bias on every edge: an outer diameter larger, a hole smaller).
struct GaugeScale {
  double mm_per_px = 0.0, edge_bias_mm = 0.0;
  double rms_mm = 0.0;  ///< the masters' diameters about the fit
  int masters = 0;
  /// Standard uncertainties of the two (the fit's covariance, its residuals' variance over
  /// 2 n - 2 degrees of freedom) and their correlation.
  double mm_per_px_u = 0.0, edge_bias_u_mm = 0.0, correlation = 0.0;
};

/// A master part's CMM figures: least-squares diameters [mm].
struct MasterFigures {
  double outer_diameter_mm = 0.0, inner_diameter_mm = 0.0;
};

/// The scale and bias that fit the masters' diameters by least squares (two equations a part);
/// throws GaugeError with fewer than 2 masters.
GaugeScale FitGaugeScale(const std::vector<GaugedPart>& parts,
                         const std::vector<MasterFigures>& masters);

/// A part in millimetres.
struct PartFigures {
  double outer_diameter_mm = 0.0, inner_diameter_mm = 0.0;
  double outer_min_mm = 0.0, outer_max_mm = 0.0, inner_min_mm = 0.0, inner_max_mm = 0.0;
  double outer_roundness_mm = 0.0, inner_roundness_mm = 0.0;
  /// Standard uncertainty of each diameter (k = 1): the scale's and bias' uncertainty at this
  /// size and the masters' scatter about the fit, which is what a silhouette cannot see of a
  /// part (its sections, burrs under the edge, the CMM's own) and dominates.
  double outer_diameter_u_mm = 0.0, inner_diameter_u_mm = 0.0;
  /// Concentricity as ISO 1101 tolerances it and a CMM reports it: the diameter of the zone
  /// round the outer circle's centre that holds the hole's, twice the centres' distance (the
  /// 20 washers' CMM figures are 2.0x the distance in the median).
  double concentricity_mm = 0.0;
  double centre_distance_mm = 0.0;
};
PartFigures ToMillimetres(const GaugedPart& part, const GaugeScale& scale);

}  // namespace mlp::toolcam
