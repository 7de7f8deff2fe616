#pragma once
/// @file 2D regions of interest on the LED frame (DIGEST 004 section 2): sub-pixel edges, holes
/// from their edge contour, faces by thresholding. The region becomes a RowMask: only its pixels
/// are processed in the laser frames.

#include "mlp/base/edge_sight.h"
#include "mlp/geometry/types.h"
#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/stripe.h"

#include <optional>
#include <vector>

namespace mlp::probe_fw {

using geometry::Vec2;

/// An edge point in sensor pixels with its grey-level gradient (dark -> bright).
struct EdgePoint {
  Vec2 position_px = Vec2::Zero();
  Vec2 gradient = Vec2::Zero();
};

/// Canny edges (OpenCV; thresholds on the Sobel gradient in full-scale fractions), each moved
/// to sub-pixel precision along its gradient by the vertex of a parabola through the gradient
/// magnitude at -1, 0, +1 px (Devernay, INRIA RR-2724, 1995).
std::vector<EdgePoint> SubpixelEdges(const Frame& led,
                                     double low_fraction = 0.05,
                                     double high_fraction = 0.15);

/// A hole: the circle (sensor pixels) fitted to the edge points around `hint_px` whose gradient
/// points away from it (dark hole in a bright face), robustly (geometry layer, MSAC + LS).
/// Empty unless such a circle exists and holds the hint.
struct HoleRoi {
  Vec2 center_px = Vec2::Zero();
  double radius_px = 0.0;
  int edge_points = 0;
  double rms_px = 0.0;
};
std::optional<HoleRoi> FindHole(const Frame& led,
                                const Vec2& hint_px,
                                double min_radius_px,
                                double max_radius_px);

/// A straight edge: the line (sensor pixels) fitted robustly to the edge points within
/// `radius_px` of `hint_px`. Empty when fewer than 12 edge points lie there or they make no line.
struct LineEdgeRoi {
  Vec2 point_px = Vec2::Zero();      ///< on the line, nearest to the hint
  Vec2 direction = Vec2::UnitX();    ///< unit
  Vec2 bright_side = Vec2::UnitY();  ///< unit normal of the line towards the lit face
  int edge_points = 0;
  double rms_px = 0.0;
  std::vector<Vec2> inliers_px;  ///< the edge points on the line
};
std::optional<LineEdgeRoi> FindLineEdge(const Frame& led, const Vec2& hint_px, double radius_px);

/// The edge as the camera saw it (base/edge_sight.h): the plane through the camera centre that
/// holds the undistorted rays of the edge points, the total-least-squares plane through the
/// origin (the smallest eigenvector of sum r r^T over the unit rays r; a straight 3D edge is a
/// plane of rays however the lens bends its image), oriented to the lit side, and the rays to
/// the outermost points along the line.
base::EdgeSight SightOfEdge(const CameraModel& camera, const LineEdgeRoi& edge);

/// Pixels of the AOI within `half_width_px` of the line.
RowMask BandMask(const Aoi& aoi, const Vec2& point_px, const Vec2& direction, double half_width_px);

/// Pixels of the AOI between radii r_in and r_out around `center_px`.
RowMask AnnulusMask(const Aoi& aoi, const Vec2& center_px, double r_in_px, double r_out_px);

/// The bright face containing `hint_px`: Otsu threshold of the LED frame, the connected region
/// holding the hint, eroded by `erode_px` (keeps the stripe window off the face's edges).
/// Empty mask when the hint is not on a bright region.
RowMask FaceMask(const Frame& led, const Vec2& hint_px, int erode_px);

}  // namespace mlp::probe_fw
