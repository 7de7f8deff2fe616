#pragma once
/// @file Sub-pixel edges of a shadow on a back-light (silhouette images: tools, ground
/// profiles): the first place a scan line's grey level rises through a threshold, refined to
/// the centroid of the signed grey steps over the 7 pixel steps around it. For an edge blurred
/// by a symmetric point spread the steps are symmetric about the edge, so the centroid is
/// unbiased (the threshold crossing by linear interpolation is biased by ~0.02 px by the blur's
/// curvature between samples; keeping only the rising steps biases towards the window's middle
/// with the noise in its tails: 17 ppm on a 3 mm pin's width). Its noise is ~0.08 px a line at
/// 2 grey levels on a 185-level step, which fits over many lines average away.
///
/// Hand-written: OpenCV's contours are whole-pixel, and its sub-pixel corner refinement is for
/// corners; a scan line per row or column is all a silhouette needs and is linear in the pixels.

#include "mlp/geometry/types.h"

#include <cstdint>

namespace mlp::geometry {

/// A grey image in memory: row-major, `width` x `height`, 8 bits a pixel, rows `stride` pixels
/// apart (0: `width`, a whole image; more: a window into a larger one).
struct GreyView {
  const std::uint8_t* pixels = nullptr;
  int width = 0, height = 0;
  int stride = 0;
  double At(int u, int v) const {
    return pixels[static_cast<long>(v) * (stride > 0 ? stride : width) + u];
  }
  /// The window of columns [u0, u0 + w) and rows [v0, v0 + h), its far sides clipped to the
  /// image; (u0, v0) must lie in the image. Crossings found in it are in its own coordinates
  /// (add u0, v0).
  GreyView Window(int u0, int v0, int w, int h) const;
};

/// Half way between a silhouette image's shadow and its back-light: the mean of its 2nd and 98th
/// percentile grey (a light source ages and a camera's gain drifts, so the level comes from
/// the image itself, not a constant).
double HalfLevel(const GreyView& image);
/// The grey level at or under which `share` of the image's pixels lie (0..255).
double GreyPercentile(const GreyView& image, double share);

/// Each row's first crossing from below `level` to at or above it, scanning from the left
/// (column 0): (u, v) with u sub-pixel; a row with no crossing adds nothing. `falling`: the
/// first crossing from at or above to below instead (a shadow's left edge on a light ground).
Points2 RowCrossings(const GreyView& image, double level, bool falling = false);
/// Each column's first crossing from below `level` to at or above it, scanning down from the
/// top (row 0): (u, v) with v sub-pixel.
Points2 ColumnCrossings(const GreyView& image, double level);
/// Every crossing of `level`, either way, along every row (u sub-pixel) and every column (v
/// sub-pixel): points on the iso-line of a silhouette of any shape (a contour across the image,
/// steep or flat), unordered; a place where the line is neither steep nor flat is found by
/// both a row and a column.
Points2 AllCrossings(const GreyView& image, double level);

/// The grey level at a sub-pixel point by bilinear interpolation; `px` must lie at least a
/// pixel inside the image's right and bottom sides.
double Bilinear(const GreyView& image, const Vec2& px);

/// Where the grey along the line p(t) = a + t u (px, u a unit vector) crosses `level` either
/// way, for t in [t_from, t_to] sampled every quarter pixel (bilinear): the crossing nearest
/// `t_near`, by linear interpolation between samples; NaN with none or with the line leaving the
/// image. A crossing along the edge's normal, as a CMM probes a feature: rows and columns cross
/// a circle's edge obliquely everywhere but at four points, and an edge whose grey profile is
/// not symmetric (a saturated back light) moves by a different amount along each.
double CrossingAlongLine(const GreyView& image,
                         double level,
                         const Vec2& a,
                         const Vec2& u,
                         double t_from,
                         double t_to,
                         double t_near);

}  // namespace mlp::geometry
