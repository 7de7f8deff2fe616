#pragma once
// The virtual machine of the acceptance test: the artefacts (spheres on stems above a table), the
// poses a five-axis head takes to look at a sphere, and one view rendered by the probe as built
// and triangulated by the firmware with the calibrated model.

#include "mlp/probe_fw/probe_model.h"
#include "mlp/sim/as_built.h"
#include "mlp/sim/render.h"
#include "mlp/sim/scene.h"

#include <cstdint>
#include <string>
#include <vector>

namespace mlp::verify {

using geometry::Pose3;
using geometry::Vec3;

/// Spheres of one diameter on stems standing on a table 60 mm below the lowest, in a finish.
sim::Scene SpheresOnStems(const std::vector<Vec3>& centres_mcs,
                          double diameter_mm,
                          const std::string& material);

/// Where the probe looks at a sphere from: the view direction `tilt_rad` from the vertical at
/// `azimuth_rad`, turned `spin_rad` about it, the probe origin `standoff_mm` from the sphere's
/// nearest point along its optical axis, and the sphere's centre `offset_mm` off that axis (in
/// the probe's x and y: the sphere elsewhere in the field of view).
struct ViewPlan {
  double tilt_rad = 0.0, azimuth_rad = 0.0, spin_rad = 0.0;
  double standoff_mm = 120.0;
  geometry::Vec2 offset_mm = geometry::Vec2::Zero();
  /// The square window read out, about where the sphere's centre projects [px].
  int aoi_px = 400;
};

/// The probe's pose in the machine (MCS from probe) for a plan.
Pose3 McsFromProbe(const Vec3& centre_mcs, double radius_mm, const ViewPlan& plan);

/// What the host has and does for one view: it knows the calibrated model and its own M, plans
/// the AOI (400 x 400 px about where the sphere's centre projects) and the columns, commands H;
/// the virtual probe renders with the as-built probe and the true M; the firmware triangulates
/// with the calibrated model.
struct ViewChain {
  const sim::AsBuiltProbe* as_built = nullptr;
  const probe_fw::ProbeModel* calibrated = nullptr;
  Pose3 true_flange_from_probe = Pose3::Identity();  ///< the virtual machine's mounting
  Pose3 host_flange_from_probe = Pose3::Identity();  ///< what the host believes M is
};

struct View {
  Pose3 mcs_from_flange = Pose3::Identity();  ///< H as commanded
  geometry::Points3 points_in_probe;          ///< the calibrated probe frame
  /// Where the host expects the sphere's centre in that frame: the plan's, through its M.
  Vec3 planned_centre_in_probe = Vec3::Zero();
};

/// Renders and triangulates one view of the sphere at `centre_mcs` in `scene` (the scene's own
/// flange_from_probe is replaced by the chain's true M).
View RenderView(const ViewChain& chain,
                sim::Scene scene,
                const Vec3& centre_mcs,
                double radius_mm,
                const ViewPlan& plan,
                double exposure,
                std::uint64_t seed);

}  // namespace mlp::verify
