#pragma once
/// @file A nominal 2D profile made of lines and arcs joined end to end (a ground contour, a
/// cam, a form tool), with what inspecting against it needs: the point and outward normal at
/// an arc length, and the closest point (foot, arc length, signed distance) of any point.
///
/// Orientation: the profile runs from its first segment's start; material lies on its right,
/// so the outward normal is the tangent turned +90 deg (left of the travel): a profile running
/// along +x with the material below has its normal along +y. Signed distances are + outside.

#include "mlp/geometry/types.h"

#include <vector>

namespace mlp::geometry {

struct ProfileSegment {
  Vec2 start = Vec2::Zero(), end = Vec2::Zero();
  bool arc = false;
  Vec2 center = Vec2::Zero();  ///< arcs: the centre
  bool ccw = true;             ///< arcs: counter-clockwise from start to end
};

struct ProfileFoot {
  double s = 0.0;  ///< arc length from the profile's start [mm]
  Vec2 point = Vec2::Zero();
  Vec2 normal = Vec2::UnitY();   ///< outward, unit
  double signed_distance = 0.0;  ///< of the query point, + outside (the normal's side)
  int segment = 0;
};

class Profile2 {
 public:
  /// Throws GeometryError (kInvalidArgument) when a segment does not start where the previous
  /// ended (within 1e-9 mm), an arc's ends are not on one circle about its centre, or a
  /// segment has no length.
  explicit Profile2(std::vector<ProfileSegment> segments);
  double Length() const { return cumulative_.back(); }
  const std::vector<ProfileSegment>& Segments() const { return segments_; }
  /// The point and outward normal at arc length s (clamped to [0, Length()]).
  ProfileFoot At(double s) const;
  /// The closest point of the profile to p.
  ProfileFoot Closest(const Vec2& p) const;

 private:
  double SegmentLength(int k) const;
  ProfileFoot OnSegment(int k, double t) const;  ///< t: length along segment k
  std::vector<ProfileSegment> segments_;
  std::vector<double> cumulative_;  ///< length up to each segment's start, then the total
};

}  // namespace mlp::geometry
