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
  using geometry::Vec3;
  const auto& proj = truth.model.projector;
  std::vector<Vec3> got, want;
  OverTheWorkingVolume(truth.model.camera,
                       [&](double u, double w, const geometry::Vec2& xy, double z) {
                         const Vec3 d = Vec3(xy.x(), xy.y(), 1.0).normalized();
                         const Vec3 o = truth.optics.WindowShift(d);
                         const Vec3 p = o + d * ((z - o.z()) / d.z());
                         const double column = proj.CommandedColumnOf(p);
                         if (column < 0 || column > proj.columns - 1) return;
                         got.push_back(probe_fw::Triangulate(model, u, w, column));
                         want.push_back(p);
                       });
  return RigidlyAligned(got, want);
}

}  // namespace mlp::test
