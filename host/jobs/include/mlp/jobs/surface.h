#pragma once
/// @file A surface patch against its nominal (ISO 1101 profile of a surface, without datum
/// re-fit: the deviations are in the frame the part was aligned in). The nominal comes from CAD
/// as points with unit normals, a "vector point" list as CMM software exports it, dense enough
/// that the surface is flat between neighbours (the error of taking the tangent plane at the
/// nearest nominal point is s^2 / (8 R) for spacing s and curvature radius R: 1 mm on R 50 is
/// 2.5 um; halve the spacing for a quarter of it).

#include "mlp/jobs/feature.h"

#include <string>
#include <vector>

namespace mlp::jobs {

struct SurfaceNominal {
  geometry::Points3 points_mcs;   ///< on the nominal surface
  geometry::Points3 normals_mcs;  ///< unit, out of the material
  double spacing_mm = 1.0;        ///< between neighbouring nominal points
  /// Measured points farther than this from the nominal surface are not on it (a neighbour
  /// face, chips).
  double band_mm = 0.5;
};

struct SurfaceMeasurement {
  /// Each point on the patch: the deviation along the nominal normal, + where material stands
  /// proud of the nominal (the surface is too high) [mm].
  std::vector<double> deviation_mm;
  geometry::Points3 points_mcs;  ///< the points those deviations belong to
  double mean_mm = 0.0, min_mm = 0.0, max_mm = 0.0, rms_mm = 0.0;
  /// The smallest zone centred on the nominal holding every point: 2 max |deviation| [mm].
  double profile_mm = 0.0;
  int points = 0;
  /// Share of the nominal points with a measured point beside them, and the area that is
  /// (share x points x spacing^2): how much of the patch the captures saw.
  double coverage = 0.0, area_mm2 = 0.0;
};

/// Throws FeatureError (a nominal without points or with normals that are not unit, fewer than
/// 50 measured points on the patch).
SurfaceMeasurement MeasureSurface(const geometry::Points3& points_mcs,
                                  const SurfaceNominal& nominal);

/// Reads a vector-point list: one point per line, "x y z i j k" (mm, unit normal out of the
/// material), blank lines and lines starting with # ignored. Throws FeatureError naming the line.
SurfaceNominal ParseVectorPoints(const std::string& text);

}  // namespace mlp::jobs
