#pragma once
/// @file Light that left the light plane (a reflection of the stripe off a neighbouring face, a
/// bore's far wall lit by its near wall) makes a second stripe that triangulates to a surface
/// that is not there. No single frame can tell it from the stripe; the sweep can. A camera ray
/// meets the first opaque surface it hits, and the light plane passes that point once: so on
/// one scan line (a sensor row, or a column where the stripe runs along the rows), the stripe's
/// centre traces its position along the line against the column lit through the sweep, and two
/// traces that
/// cover the same pixels at columns far apart cannot both be direct light. The weaker trace is
/// the indirect one (a reflection loses light); when neither is clearly weaker, both are
/// rejected: a ghost must never reach a cloud, a lost point costs less. Spacetime reasoning
/// after Curless & Levoy, "Better optical triangulation through spacetime analysis", ICCV 1995.

#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/stripe.h"

#include <cstddef>
#include <vector>

namespace mlp::probe_fw {

/// A stripe centre as the sweep saw it: which frame (sweep order) and which column lit it.
struct SweepObservation {
  StripePoint stripe;
  double column = 0.0;
  int frame = 0;
  bool indirect = false;  ///< set by RejectIndirectLight
  /// Kept out of the cloud but still direct light for the sweep's later tests: a centre whose
  /// line orders almost as well without it (RejectOutOfOrder). Marked indirect, it was taken out
  /// of the references the later tests order the line against, and reflections they had caught
  /// got through (corpus 8080 scene 70).
  bool doubted = false;
};

struct GhostOptions {
  /// Observations of one row in nearby frames (see max_gap_frames) belong to one
  /// trace when their centres are this close [px]. Wider than a stripe's travel per frame
  /// (~3 px at 2 columns for the reference probe), narrower than the double-peak window.
  double link_gate_px = 12.0;
  /// Once a trace has moved, the next centre must be this close to where its motion predicts
  /// [px, times the square root of the frames bridged]: a reflection crossing the stripe moves
  /// at another speed and is
  /// not taken on.
  double track_px = 2.0;
  /// A trace carries on across this many frames without the stripe (speckle drops it, the
  /// double-peak test drops it where a ghost is beside it); its motion bridges the gap.
  int max_gap_frames = 4;
  /// A pixel ray lit at two columns more than this far apart saw one of them indirectly. The
  /// sheet lights a point over about +-1.5 columns.
  double same_ray_columns = 4.0;
  /// A trace is clearly the stronger when its median amplitude is this many times the other's.
  double dominance = 1.5;
  /// The way direct light moves along a row (row scans) and along a column (column scans) as the
  /// column grows: +1 or -1, 0 unknown (DirectMotion). For every face that both the camera and
  /// the projector see, the stripe moves one way along the epipolar line (the ordering
  /// constraint of stereo: Baker and Binford, IJCAI 1981); light reflected once by a plane comes
  /// from the projector's mirror image, whose baseline is turned round: it moves the other way.
  double row_motion_sign = 0.0, column_motion_sign = 0.0;
  /// A trace whose centres moved at least this far [px] has a direction to judge.
  double min_motion_px = 1.0;
};

/// The way direct light moves along each scan axis for this probe (GhostOptions' signs): the
/// image of the optical axis' point on the central column's light plane, and of the next column's
/// sheet at the same depth. An axis along which the stripe moves less than a tenth of its whole
/// motion gets 0 (no rule there).
void DirectMotion(const ProbeModel& model, double* row_sign, double* column_sign);

/// Marks `indirect` on every observation of a trace that moves against direct light's way (when
/// the options give it), and of a trace that loses a conflict: against one that moves the direct
/// way while it has no direction, else against a clearly stronger one, else against one several
/// times longer; both traces of a conflict where none of this tells. Returns how many were marked.
std::size_t RejectIndirectLight(std::vector<SweepObservation>* observations,
                                const GhostOptions& options);

/// A camera ray meets one opaque surface, at one depth, through the whole sweep: observations
/// of one pixel (scan axis, line, centre rounded) in several frames whose light planes put that
/// ray's point at depths further apart than `RayOptions` allows cannot all be direct. A
/// reflection that stands still in the image while the sweep moves on (a stray line off a
/// fixture), or sits where another frame's stripe passed, lights one pixel from light planes
/// millimetres apart; trace-based tests see no motion to judge there. Which one is direct the
/// ray alone cannot tell: all of them are marked `indirect` (a lost pixel costs less than a
/// wrong one). Returns how many were marked.
struct RayOptions {
  /// Depths on one ray further apart than the larger of this [mm] and `pixels` times the depth
  /// one pixel along the line moves on the observation's own light plane.
  double min_depth_mm = 0.1;
  double pixels = 3.0;
};
std::size_t RejectRayConflicts(const ProbeModel& model,
                               const RayOptions& options,
                               std::vector<SweepObservation>* seen);

/// The ordering constraint over the whole sweep: on one scan line, direct light moves one way
/// as the column grows (GhostOptions' signs; Baker and Binford, IJCAI 1981), so the line's
/// direct observations, ordered by column, advance along the line. A reflection standing where
/// no other frame's stripe passed (a coarse sweep: 100 px between frames) has no competitor on
/// its epipolar line nor on its pixel, but its column is out of order with the direct light on
/// both sides of it. Keeps what every longest ordered sequence of each line holds (within
/// `tolerance_px` back-steps: the centres' noise in a fine sweep) and marks the rest `indirect`:
/// two members that could take the same place in it (a reflection just behind the stripe's last
/// centre) both go. The members of a longest sequence that a sequence one member shorter
/// leaves out (a line that orders almost as well another way: a reflection trailing the stripe
/// that takes over where the stripe leaves the image) are marked `doubted`: out of the cloud,
/// still references for the tests after this one. Lines of an axis whose sign is 0 are left
/// alone. Returns how many were marked indirect or doubted.
std::size_t RejectOutOfOrder(double row_sign,
                             double column_sign,
                             double tolerance_px,
                             std::vector<SweepObservation>* seen);

/// A reflection off a flat face comes from the projector's mirror image, so it moves against
/// direct light's way (GhostOptions' signs). In a fine sweep the trace test links its centres
/// and sees that; in a coarse one (50-150 px between frames) nothing links, and the ordering test
/// keeps the longest ordered sequence of a line, which may end with the reflection's last frame
/// where it falls into order with the direct light beyond it (issue 50: corpus 7171, scene 41: a
/// reflection walking back 95, 80, 61 px through frames 0-3, its last frame kept 12 mm in front
/// of a cylinder). Direct light never steps back on a line (Baker and Binford, IJCAI 1981; only
/// an occluding edge in front of a face can, once): a run of at least `min_steps` back-steps
/// of over `tolerance_px` between sheets at most `max_sheet_gap` apart in the sweep's column
/// order (frames may sweep either way) is indirect, all of it.
/// Lines of an axis whose sign is 0 are left alone. Returns how many were marked.
std::size_t RejectBackwardRuns(double row_sign,
                               double column_sign,
                               double tolerance_px,
                               int min_steps,
                               int max_sheet_gap,
                               std::vector<SweepObservation>* seen);

/// A camera pixel takes direct light once in a sweep: between two neighbouring sheets the direct
/// stripe sweeps the stretch of its line between their centres, at those sheets' depths. A
/// centre lying inside a stretch another pair of sheets swept, from a sheet far from theirs, was
/// lit twice from planes millimetres apart, and one of the two is not direct. The stretches are
/// swept by the points still held and by the stripes rejected for their shape (`evidence`: an
/// over-exposed stripe is dropped but is still light there). Issue 50, corpus 7272 scene 19: a
/// reflection at 0.2 of an over-exposed stripe lit a sphere alone for 11 frames while the direct
/// sheet had not reached it, points up to 52 mm in front of it; the direct, saturated stripe
/// swept those pixels later, 40-65 px a frame over the sphere's cap (1,500 points beyond 0.2 mm
/// -> 180 with 120 px, 436 with 40). Which is direct the pixel cannot tell: the points held
/// there are marked (a lost point costs less than a wrong one); evidence is never a point. Only
/// the epipolar scan's lines (an axis with a sign) are judged. Pairs of sheets on two different
/// lights can make a stretch too: that costs points, never keeps one (tuning corpus 5050: 0.07 %
/// of its points). Returns how many were marked.
struct SweptOptions {
  double margin_px = 3.0;      ///< a stretch shrunk by this at each end (a saturated centre's play)
  double max_step_px = 120.0;  ///< neighbouring sheets further apart on a line sweep nothing
  int max_sheet_gap = 2;       ///< sheets this close in column order are neighbours (a frame lost)
};
std::size_t RejectSweptTwice(double row_sign,
                             double column_sign,
                             const std::vector<SweepObservation>& evidence,
                             const SweptOptions& options,
                             std::vector<SweepObservation>* seen);

/// The ordering constraint against the light the firmware refused. A stripe at full scale is
/// dropped (its centre is not measured) but it is the brightest light of its frame, most likely
/// the direct stripe; direct light never steps back along a line as the sheets go on, so a
/// point held at a later sheet behind where an earlier sheet's clipped stripe already was (by
/// more than `tolerance_px`, the line's sign as in RejectOutOfOrder), or at an earlier sheet
/// beyond a later one's, is not direct. Issue 50, corpus 7373 scene 182: an over-exposed
/// cylinder whose clipped stripe left the part after frame 4, and a 0.3 mirror reflection walking
/// back through frames 7-8 with nothing to order it against: its last frame was kept, 517
/// points up to 289 mm off. Evidence not at full scale (a double peak, a one-pixel spike) is
/// not used: a hot pixel would order a whole line. A clipped reflection costs direct points
/// behind it, never keeps one. Only the epipolar scan's lines are judged. Returns how many were
/// marked.
std::size_t RejectBehindClippedLight(double row_sign,
                                     double column_sign,
                                     const std::vector<SweepObservation>& evidence,
                                     double tolerance_px,
                                     std::vector<SweepObservation>* seen);

/// A reflection is a whole stripe of its own: where the sweep's tests found most of one frame's
/// stripe indirect, its few members left (where it fades out at the ends of the lit band, where
/// the frame before lost it) are the same light. Within each frame and scan axis, centres on
/// lines at most `max_line_gap` apart whose positions differ by at most `link_gate_px` are one
/// stripe; a stripe of which more than `share` is marked is marked whole. Returns how many more
/// were marked (issue 50: corpus 7171, scene 41, the 4 points left of a reflection 11-44 mm off).
std::size_t SpreadAlongStripes(double link_gate_px,
                               int max_line_gap,
                               double share,
                               std::vector<SweepObservation>* seen);

/// The rate along the line. A smooth surface takes the sweep's sheets at a rate along each line
/// that changes slowly from sheet to sheet; a reflection kept at the end of a line's sequence,
/// cut off from the rest by sheets the line never saw (a coarse sweep, frames a dropout took),
/// is in order with them, so the ordering tests keep it, but it breaks the rate (issue 50,
/// corpus 7777: scene 45, sheets at 14, 221, 428 px, then a reflection at 812 where the rate
/// puts 842). An end member after a gap of at least `min_gap_sheets` whose position lies off
/// the rate of the two members nearest it (extrapolated by column) by more than `share` of the
/// extrapolated step plus `tolerance_px` is marked; where a third member shows the rate itself
/// changing (a sphere towards its limb), by that change times the gap more. The line's sign as in
/// RejectOutOfOrder (only lines of an axis with a sign). Returns how many were marked.
struct RateOptions {
  int min_gap_sheets = 2;
  /// A plane's sheets land at a rate that changes by a few per cent a sheet; the centres'
  /// scatter is under a pixel.
  double share = 0.05;
  double tolerance_px = 3.0;
};
std::size_t RejectOffRate(double row_sign,
                          double column_sign,
                          const RateOptions& options,
                          std::vector<SweepObservation>* seen);

/// The ordering constraint across the scan axes. Where the stripe runs along the epipolar lines
/// (a face the light grazes) the other axis' scan finds it, and those observations have no line
/// of their own to be ordered on: RejectOutOfOrder cannot see them. Each lies on an epipolar line
/// all the same (the line through its pixel), where the epipolar scan's direct observations
/// order position against column; a direct observation fits between the line's neighbours by
/// column (within `tolerance_px` along the line). A reflection lit from the projector's mirror
/// image, running along the rows, triangulates tens of millimetres in front of the part it lies
/// on and breaks that order (issue 50: corpus 5050, scene 130). Only the cross observations are
/// marked: the epipolar lines' own order was settled by RejectOutOfOrder. Nothing happens unless
/// exactly one axis has a sign (the probe's baseline along the rows or along the columns).
/// Returns how many were marked.
std::size_t RejectAcrossOrder(double row_sign,
                              double column_sign,
                              double tolerance_px,
                              std::vector<SweepObservation>* seen);

}  // namespace mlp::probe_fw
