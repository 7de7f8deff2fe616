#pragma once
/// @file A glossy face's reflectance changes across the stripe (near a glint, along a machining
/// lay): the profile is the sheet's Gaussian G(x - x0) times R(x), and with R = R0 exp(g (x - x0))
/// over the stripe's width that is a Gaussian of the same width centred at x0 + g sigma^2: the
/// centre of mass moves towards the brighter side, tens of micrometres on ground steel, and no
/// single frame can tell (the profile stays symmetric). The sweep can: the sheet sends the same
/// light in every frame, so the stripe's light (its mass) in the frames before and after, a few
/// pixels along the same scan line, samples R there; g = d ln(mass) / d along, and the centre is
/// moved back by g sigma^2 (sigma^2 the profile's second moment, which the tilt leaves as it
/// was). The idea of reading reflectance through the sweep is Curless and Levoy's spacetime
/// analysis (ICCV 1995), which removes the same bias at reflectance edges.

#include "mlp/probe_fw/ghost.h"

#include <cstddef>
#include <vector>

namespace mlp::probe_fw {

struct ReflectanceOptions {
  /// Neighbours on the same scan line in the frames before and after, within this [px] (the
  /// stripe's travel per frame, as ghost.h's link gate).
  double neighbour_gate_px = 12.0;
  /// A correction larger than this [px] means the reflectance is not smooth over the stripe (an
  /// edge, a glint's rim): the point is dropped rather than moved that far.
  double max_shift_px = 0.5;
  /// The slope is averaged over the same frame's centres on the scan lines within this many of
  /// the point's own and within smooth_along_px along them (a reflectance varies smoothly over
  /// the face, speckle from grain to grain).
  int smooth_lines = 2;
  double smooth_along_px = 3.0;
};

struct ReflectanceCounts {
  std::size_t corrected = 0;  ///< centres moved by the reflectance slope
  std::size_t dropped = 0;    ///< slope too steep to correct: marked `indirect`, not a point
};

/// Moves each direct observation's centre (along its scan line) back by the reflectance slope's
/// shift; observations with no neighbour frame on their line are left as they are.
ReflectanceCounts CorrectReflectanceSlope(std::vector<SweepObservation>* observations,
                                          const ReflectanceOptions& options);

}  // namespace mlp::probe_fw
