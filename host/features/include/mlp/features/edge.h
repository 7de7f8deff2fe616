#pragma once
/// @file A straight part edge from the LED frame (seed 004: the line of a six-point alignment,
/// and an edge feature): each capture's edge sight (base/edge_sight.h, found by the firmware on
/// its LED frame) is a plane through the camera centre; met with the face the edge bounds, it is
/// a segment of the edge in 3D. Segments from views along the edge make its line.
///
/// Why the LED frame and not the cloud: the laser stripe ends at an edge over a window of
/// pixels and its last points are biased by that window (a column step); the LED frame's
/// sub-pixel edge is one intensity step, and its rays near the image centre are nearly along the
/// face's normal, so an error in the face's height barely moves the edge.

#include "mlp/base/edge_sight.h"
#include "mlp/features/feature.h"
#include "mlp/geometry/types.h"

#include <string>
#include <vector>

namespace mlp::features {

/// A capture's edge sight in the machine frame.
struct EdgeView {
  std::string capture_id;
  geometry::Vec3 camera_mcs = geometry::Vec3::Zero();   ///< the camera centre
  geometry::Vec3 normal_mcs = geometry::Vec3::UnitX();  ///< the sight plane's, lit face on +
  geometry::Vec3 first_ray_mcs = geometry::Vec3::UnitZ(), last_ray_mcs = geometry::Vec3::UnitZ();
  double rms_px = 0.0;
  int points = 0;
};

EdgeView EdgeViewInMcs(const base::EdgeSight& sight,
                       const geometry::Pose3& mcs_from_probe,
                       const std::string& capture_id);

/// An edge on a face, from one view or several.
struct EdgeMeasurement {
  /// On the face; its direction is X of a frame whose Y points into the material and Z along
  /// the face's normal (so a part's front edge runs +X when the face's normal is +Z).
  geometry::Line3 line_mcs;
  geometry::Vec3 into_material_mcs = geometry::Vec3::UnitY();  ///< in the face, unit
  double span_mm = 0.0;          ///< from the first segment's start to the last one's end
  double straightness_mm = 0.0;  ///< the segments' ends about the line, largest distance
  int views = 0, points = 0;
  double rms_px = 0.0;  ///< largest of the views'
  struct Segment {
    geometry::Vec3 first_mcs, last_mcs;
    int points = 0;       ///< the view's edge points (one per sensor row or column)
    double rms_px = 0.0;  ///< about their line in the image
    /// Across the edge, in the face, per mm the face stands higher: how a face height error
    /// moves this view's segment (its mid ray's slope).
    double across_per_height = 0.0;
  };
  std::vector<Segment> segments_mcs;
};

/// Throws FeatureError: no view, a ray that does not meet the face in front of the camera or
/// meets it at a grazing angle (more than 80 deg from its normal), views that see the lit face
/// on opposite sides, or segments that do not make one line.
EdgeMeasurement MeasureEdge(const std::vector<EdgeView>& views, const geometry::Plane& face);

/// The nominal of an edge feature: where the face (the lit, measured one) meets a wall.
struct EdgeNominal {
  PlaneNominal face;
  geometry::Vec3 point_mcs = geometry::Vec3::Zero();  ///< on the edge
  /// The wall's outward normal: across the edge, out of the material (in the face after
  /// projection).
  geometry::Vec3 wall_normal_mcs = geometry::Vec3::UnitX();
  double length_mm = 0.0;  ///< the views spread over this much of the edge, centred on the point
  int views = 2;           ///< along the edge, 1..8
  /// The edge's direction (face normal x wall normal, unit) and the outward normal in the face.
  geometry::Vec3 Direction() const;
  geometry::Vec3 Outward() const;
  void Check() const;  ///< throws FeatureError
};

/// The edge against its nominal: the offset (+: the wall stands proud, material beyond the
/// nominal) at the nominal point, and the angle in the face [deg].
struct EdgeDeviation {
  double offset_mm = 0.0;
  double angle_deg = 0.0;
  /// Their standard uncertainties (k = 1) from what was seen, as BoreMeasurement's
  /// diameter_u_mm: each view's edge points about their image line (rms_px over the root of
  /// their count across, rms_px sqrt(12) / points^1.5 in direction; one point per sensor row
  /// or column, so the line is about `points` px long), carried through the line's fit over
  /// the views, and the face's height_u_mm through the views' ray slopes (common to all).
  /// Not the calibration's share.
  double offset_u_mm = 0.0;
  double angle_u_deg = 0.0;
  geometry::Vec3 found_mcs = geometry::Vec3::Zero();  ///< the measured edge at the nominal point
};
/// `face_height_u_mm`: the face's height uncertainty (PlaneMeasurement::height_u_mm), 0 if
/// not known.
EdgeDeviation CompareEdge(const EdgeMeasurement& m,
                          const EdgeNominal& n,
                          double face_height_u_mm = 0.0);

}  // namespace mlp::features
