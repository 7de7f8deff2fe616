#pragma once
// Ground truth of a probe as built with the optics no probe model describes (sim/as_built.h):
// how a model's triangulation is judged against the probe that renders the frames.

#include "mlp/sim/as_built.h"

#include "probe_truth.h"

namespace mlp::test {

/// As TriangulationVsTruth, over the probe as built: each true point is where the real camera
/// ray of pixel (u, w) (through the window) meets the plane z = 105, 120, 135 mm, lit by the
/// commanded column whose (curved) sheet reaches it through the (non-linear) mirror.
inline TriangulationError TriangulationVsAsBuilt(const sim::AsBuiltProbe& truth,
                                                 const probe_fw::ProbeModel& model) {
  std::vector<geometry::Vec3> got, want;
  sim::WorkingVolumePoints(truth, model, nullptr, &got, &want);
  return RigidlyAligned(got, want);
}

}  // namespace mlp::test
