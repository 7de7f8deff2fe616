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
};

/// Marks `indirect` on every observation of a trace that conflicts with a clearly stronger one,
/// and on both traces of a conflict where neither is. Returns how many were marked.
std::size_t RejectIndirectLight(std::vector<SweepObservation>* observations,
                                const GhostOptions& options);

}  // namespace mlp::probe_fw
