#pragma once
/// @file The grinding wheel's section as the camera sees it (seed 001).
///
/// Seed 001 grinds with a double-bevel wheel with a tip arc (Fig. 1, 6): two straight flanks,
/// each at the bevel's half angle from the wheel's axis, tangent to the nose's arc of radius R
/// at the tip. Seen from above, its section is a rounded wedge pointing along `tip_dir`: the
/// nose's arc spans +-(90 deg - half angle) about the tip, the flanks run back from there. Where
/// the profile's normal turns further than that from the tip, or the stock is deep, the flanks
/// cut too, and the edge of the region a stroke removed is part arc, part flank: the seed
/// measures the error to that "theoretical edge" (Fig. 6, 15), not to a circle. A round-nosed
/// wheel is the nose's disc alone (no flanks).

#include "mlp/geometry/types.h"

#include <vector>

namespace mlp::grind {

struct WheelBevel {
  bool on = false;               ///< off: a round-nosed wheel (the nose's disc alone)
  double half_angle_deg = 30.0;  ///< each flank from the wheel's axis
  geometry::Vec2 tip_dir = -geometry::Vec2::UnitY();  ///< from the hub to the tip (image, unit)
  void Validate() const;                              ///< throws GrindInputError naming the field
};

/// A wheel's section with its nose's centre at the origin (mm, the image's x right, y up).
class WheelSection {
 public:
  WheelSection(double nose_radius_mm, const WheelBevel& bevel);
  /// Exact signed distance to the section's edge (negative inside): 1-Lipschitz, so a
  /// renderer may take |f| as a bound on the distance to the edge.
  double SignedDistanceMm(const geometry::Vec2& p) const;
  /// Every t with p + t u on the edge (at most two: the section is convex), ascending.
  std::vector<double> Crossings(const geometry::Vec2& p, const geometry::Vec2& u) const;
  /// The nearest point of the edge to p lies on the nose's arc (not on a flank).
  bool NearestOnArc(const geometry::Vec2& p) const;
  double nose_radius_mm() const { return r_; }

 private:
  // p in the wedge's frame: along the axis towards the hub, and across it (both signs).
  geometry::Vec2 Local(const geometry::Vec2& p) const;
  double r_;
  bool bevel_;
  geometry::Vec2 axis_, across_;      // towards the hub; a quarter turn from it
  double cos_b_ = 1.0, sin_b_ = 0.0;  // the half angle
};

}  // namespace mlp::grind
