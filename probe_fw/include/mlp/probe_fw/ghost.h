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

}  // namespace mlp::probe_fw
