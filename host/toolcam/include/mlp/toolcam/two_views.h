#pragma once
/// @file Two illuminator / detector pairs (seed 000 example 7, Fig. 5): a second back-lit camera
/// looks at the tool from another direction round the spindle axis, the same strobe pulses
/// freezing both. One camera sees only the tool's y (across its image) and z: a tool moved
/// along its view looks the same. Two, their views turned `view_deg` apart about the spindle
/// axis, triangulate the third coordinate: the spindle axis' place in both directions across
/// it, each edge as a point in space, and the stylus' ball centre.
///
/// Frames: camera A's tool frame, x along A's view (away from A), y across A's image, z up the
/// spindle. B's view is A's turned `view_deg` about +z (the way the tool turns), so B's image
/// shows y_b = -sin(view) x + cos(view) y across, and B sees the tool as A does `view_deg`
/// of turn later.
///
/// The pair's angle comes from the mount, to within `tolerance_deg`, and is measured from the
/// tool itself: each flute's extreme reaches B's +y side `view_deg` after A's, the pulses
/// being the same. That measured angle is what the triangulation uses.

#include "mlp/geometry/types.h"
#include "mlp/toolcam/measure.h"

#include <vector>

namespace mlp::toolcam {

/// How the second pair is mounted against the first.
struct SecondView {
  double view_deg = 90.0;       ///< B's view turned from A's about the spindle axis (+z) [deg]
  double tolerance_deg = 10.0;  ///< how far off the mount's angle may be [deg]
};

/// Views nearer parallel (or opposite) than this do not triangulate: the depth's error is the
/// views' error over sin(view) (1 / sin 15 deg = 3.9 times).
constexpr double kMinViewAngleDeg = 15.0;

/// A point seen by camera A at (y_a, h_a) and by camera B at (y_b, h_b), each in its own tool
/// frame [mm], B's view turned `view_deg` from A's: the point in A's frame, its z the mean of
/// the heights (each camera's calibration puts the same machine height at the same h). Throws
/// ToolInputError when the views are within kMinViewAngleDeg of parallel or opposite.
geometry::Vec3 Triangulate(double y_a, double h_a, double y_b, double h_b, double view_deg);

struct ToolIn3d {
  ToolMeasurement a, b;       ///< each camera's own measurement (both flanks in each)
  double view_deg = 0.0;      ///< B's view from A's, as the flutes' angles show it
  double view_rms_deg = 0.0;  ///< the flutes' spread about it
  /// The spindle axis at the reference height, off where both cameras' calibrations put it,
  /// in A's frame [mm] (x: along A's view, which A alone cannot see; z: 0).
  geometry::Vec3 axis_offset_mm{0, 0, 0};
  double tip_h_mm = 0.0;             ///< the longest edge's tip, the views' mean
  double tip_disagreement_mm = 0.0;  ///< A's tip less B's: the calibrations' heights
  double depth_gain = 1.0;           ///< 1 / |sin(view)|: the depth's error over a view's
  /// Per flute (A's order): its edge at the reference height, at the series' angular position
  /// 0 (z: the reference height), as a point in A's frame from where the calibrations put the
  /// spindle axis [mm]; its radius the views' mean, and A's radius less B's.
  std::vector<geometry::Vec3> edge_mm;
  std::vector<double> radius_mm, radius_disagreement_mm;
  /// Which of B's flutes is A's flute k.
  std::vector<int> b_flute;
};

/// The tool from both cameras' series of the same pulses (the same angular positions, each
/// series with its own camera's calibration), the tool wholly in view of each (both flanks:
/// each camera measures the axis across its own image). Throws ToolInputError when the series
/// are not of the same pulses or the mount is unusable, ToolError when a camera does not show
/// both flanks or the flutes do not pair within the mount's tolerance.
ToolIn3d MeasureToolFromTwoViews(const ToolSeries& a,
                                 const ToolSeries& b,
                                 const ToolDescription& nominal,
                                 const SecondView& mount,
                                 const MeasureOptions& options = {});

}  // namespace mlp::toolcam
