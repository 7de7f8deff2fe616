#pragma once
/// @file What a job measures from, gathered by the service before the job runs: the captures'
/// points mapped into the machine frame, the probe that took them, the LED frames' edges, and
/// the calibration they were mapped with.

#include "mlp/features/edge.h"
#include "mlp/geometry/types.h"

#include <string>
#include <vector>

namespace mlp::jobs {

struct Evidence {
  geometry::Points3 points_mcs;
  std::string probe_serial;
  std::vector<features::EdgeView> edges;  ///< of the captures whose firmware found an edge
};

/// The calibration the points were mapped with, as the plausibility gate weighs it.
struct CalibrationFacts {
  std::string calibration_id;
  std::string probe_serial;
  double age_h = 0.0;  ///< hours since it was made
};

}  // namespace mlp::jobs
