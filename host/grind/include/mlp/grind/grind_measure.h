#pragma once
/// @file The profile error at one cutting point during curve grinding (seed 001).
///
/// The NC gives the theoretical wheel-nose centre C and cutting point Mi (Mi on the nominal,
/// C = Mi + R n). From the frame after the stroke:
/// 1. the actual contour: every sub-pixel crossing of the half grey level (geometry/contour.h)
///    within 2 R of Mi;
/// 2. Mr, the contour on the line C-Mi: the seed's search in its six cases (contour_search.h),
///    then a line through the contour points within 3 px of there intersected with C-Mi
///    (sub-pixel);
/// 3. d = |Mr - Mi|: good when d <= e; else under-feed (material left, Mr between C and Mi) or
///    over-feed (over-cut, Mr beyond Mi);
/// 4. under-feed: where the wheel really was, from the frames before and after the stroke:
///    the after-contour's points that were inside the material before (the edge of the
///    region the stroke removed: the real nose's arc, and a double-bevel wheel's flanks where
///    they cut); for directions within +-90 deg of the profile normal, each point's distance
///    along it to the wheel's theoretical edge (wheel.h: the nose circle, or arc and flanks); the
///    direction with the smallest spread is the error's, its mean distance the size (0.5 deg
///    steps, then 0.01 deg). No such points (the wheel did not cut): the normal and the
///    excess d. When no shift explains the arc (its spread over 1 um: the nose is worn
///    smaller), a circle through the edge's arc points instead: its centre's shift plus its
///    lost radius along the normal is the error;
/// 5. the compensation the motion controller receives: under-feed, the wheel moved back by
///    the error found (towards the material); over-feed, along the normal away from it by
///    the over-cut + 2 e (retract safely).

#include "mlp/geometry/contour.h"
#include "mlp/geometry/profile2d.h"
#include "mlp/grind/grind_frame.h"

#include <string>
#include <vector>

namespace mlp::grind {

enum class Feed { kGood, kUnderFeed, kOverFeed };
const char* ToString(Feed f);

struct PointResult {
  Feed feed = Feed::kGood;
  geometry::Vec2 mr_mm = geometry::Vec2::Zero();  ///< the actual contour on C-Mi
  double d_mm = 0.0;                              ///< |Mr - Mi|
  /// The seed's case on the half-level contour (1..6; 0: one column; -1: it found nothing, a
  /// frame whose back light is shadowed there).
  int search_case = 0;
  /// Mr from the edge's local contrast along C-Mi (issue 55); false: the seed's search's.
  bool local_edge = false;
  bool search_by_rows = false;  ///< the rows played the columns' part (a steep contour)
  /// A speck passed over on C-Mi before the part's edge (a droplet or chip in the light, a
  /// soft shadow's edge: dark, then light again within 0.15 mm): how far before Mr it lay; 0:
  /// none.
  double speck_passed_mm = 0.0;
  /// Under-feed: the wheel's error found (unit direction, size); otherwise the normal and d.
  geometry::Vec2 error_dir = geometry::Vec2::UnitY();
  double error_mm = 0.0;
  bool wheel_cut = true;  ///< under-feed: the stroke removed material (else normal + d)
  int edge_points = 0;    ///< on the removed region's edge
  /// Of those, left out as no wheel position's (a droplet, a burr: over 3 um off the wheel's
  /// edge at the shift found, and 4 robust sigma); the search then ran again without them.
  int left_out = 0;
  double spread_mm = 0.0;  ///< their distances' spread at the direction found (or the circle's rms)
  /// The nose's radius when a shift did not explain its arc (spread over 1 um: worn, or not
  /// round) or a circle through the arc put its radius over 3 sigma off the wheel's (worn), and
  /// the circle gave the error; 0 otherwise.
  double nose_radius_mm = 0.0;
  /// Under-feed with a shift explaining the arc: the seed's smallest-spread answer (error_dir
  /// and error_mm are least squares' over the same edge, or the normal and d when that cannot
  /// fix the direction to 5 deg at 3 sigma, or a nose worn by d would explain the arc as well
  /// and lies over 5 deg from it: direction_determined false).
  geometry::Vec2 seed_error_dir = geometry::Vec2::UnitY();
  double seed_error_mm = 0.0;
  double direction_sigma_deg = 0.0;  ///< the error's direction (shift or circle), 1 sigma
  bool direction_determined = true;
  geometry::Vec2 compensation_mm = geometry::Vec2::Zero();  ///< for the motion controller
  /// Why no compensation is given for a point measured off (empty: none withheld): the fit left
  /// edge points out as no wheel position's, so something stands on the edge (issue 55: no
  /// compensation from a point with a droplet or burr on it). d and the class stand.
  std::string compensation_withheld;
  std::vector<geometry::Vec2> contour_mm;  ///< the actual contour near Mi (for pictures)
  /// Not measured: why (a job's other points still are; set by the job's caller, never by
  /// MeasurePoint, which throws GrindError).
  std::string refused;
};

struct PointInput {
  geometry::GreyView before, after;
  geometry::Vec2 c_mm, mi_mm;  ///< the NC's wheel-nose centre and cutting point
};

/// Throws GrindError when the frame shows no contour on the line C-Mi (or the frames do not
/// match the camera).
/// `bevel`: the wheel's flanks (wheel.h); off, a round nose.
PointResult MeasurePoint(const PointInput& in,
                         const geometry::Profile2& nominal,
                         const GrindCamera& camera,
                         double wheel_radius_mm,
                         double limit_mm,
                         const WheelBevel& bevel = {});

}  // namespace mlp::grind
