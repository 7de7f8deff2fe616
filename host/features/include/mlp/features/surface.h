#pragma once
/// @file A surface patch against its nominal (ISO 1101 profile of a surface): without a best
/// fit, the deviations in the frame the part was aligned in (its place and form); with one
/// (`best_fit`), after the rigid motion that best lays the points on the nominal (its form
/// alone, the profile without datum). The nominal comes from CAD
/// as points with unit normals, a "vector point" list as CMM software exports it, dense enough
/// that the surface is flat between neighbours (the error of taking the tangent plane at the
/// nearest nominal point is s^2 / (8 R) for spacing s and curvature radius R: 1 mm on R 50 is
/// 2.5 um; halve the spacing for a quarter of it).

#include "mlp/features/feature.h"

#include <string>
#include <vector>

namespace mlp::features {

struct SurfaceNominal {
  geometry::Points3 points_mcs;   ///< on the nominal surface
  geometry::Points3 normals_mcs;  ///< unit, out of the material
  double spacing_mm = 1.0;        ///< between neighbouring nominal points
  /// Measured points farther than this from the nominal surface are not on it (a neighbour
  /// face, chips).
  double band_mm = 0.5;
  /// Lay the points on the nominal first by the rigid motion minimising the squared normal
  /// deviations (point-to-plane ICP, Chen & Medioni 1992), then take the deviations.
  bool best_fit = false;
};

/// The rigid motion of a best fit, applied to the measured points: p' = R (p - c) + c + t.
struct SurfaceBestFit {
  geometry::Vec3 rotation_rad = geometry::Vec3::Zero();  ///< rotation vector of R
  geometry::Vec3 translation_mm = geometry::Vec3::Zero();
  geometry::Vec3 about_mcs = geometry::Vec3::Zero();  ///< c: the points' centroid
  int iterations = 0;
  bool converged = false;
  /// Motions the patch does not fix (it slides along them: a plane in its own plane, a
  /// cylinder along and about its axis), left out of the fit, in words.
  std::vector<std::string> not_determined;
};

struct SurfaceMeasurement {
  /// Each point on the patch: the deviation along the nominal normal, + where material stands
  /// proud of the nominal (the surface is too high) [mm].
  std::vector<double> deviation_mm;
  /// The points those deviations belong to (after a best fit: moved by it onto the nominal).
  geometry::Points3 points_mcs;
  double mean_mm = 0.0, min_mm = 0.0, max_mm = 0.0, rms_mm = 0.0;
  /// The smallest zone centred on the nominal holding every point: 2 max |deviation| [mm].
  double profile_mm = 0.0;
  int points = 0;
  /// Share of the nominal points with a measured point beside them, and the area that is
  /// (share x points x spacing^2): how much of the patch the captures saw.
  double coverage = 0.0, area_mm2 = 0.0;
  SurfaceBestFit best_fit;  ///< when the nominal asked for one
};

/// Throws FeatureError (a nominal without points or with normals that are not unit, fewer than
/// 50 measured points on the patch).
SurfaceMeasurement MeasureSurface(const geometry::Points3& points_mcs,
                                  const SurfaceNominal& nominal);

/// Reads a vector-point list: one point per line, "x y z i j k" (mm, unit normal out of the
/// material), blank lines and lines starting with # ignored. Throws FeatureError naming the line.
SurfaceNominal ParseVectorPoints(const std::string& text);

}  // namespace mlp::features
