#include "views.h"

#include "mlp/probe_fw/triangulate.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace mlp::verify {
namespace {

constexpr double kColumnStep = 2.0;
constexpr double kStemRadiusMm = 4.0;
constexpr double kTableBelowMm = 60.0;
constexpr double kTableReflectance = 0.4;

}  // namespace

sim::Scene SpheresOnStems(const std::vector<Vec3>& centres_mcs,
                          double diameter_mm,
                          const std::string& material) {
  double lowest = INFINITY;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (const Vec3& c : centres_mcs) {
    lowest = std::min(lowest, c.z());
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
  }
  const double table_z = lowest - kTableBelowMm;
  std::vector<sim::SolidPtr> parts;
  for (const Vec3& c : centres_mcs) {
    parts.push_back(
        sim::MakeNamedFinish(sim::MakeSphere(c, diameter_mm / 2, kTableReflectance), material));
    // The stem ends inside the sphere, 0.8 R below its centre: its top never shows.
    const double top = c.z() - 0.8 * diameter_mm / 2;
    parts.push_back(sim::MakeRevolution(Vec3(c.x(), c.y(), table_z), Vec3::UnitZ(), top - table_z,
                                        kStemRadiusMm, kStemRadiusMm, kTableReflectance));
  }
  parts.push_back(sim::MakeBox(Vec3(lo.x() - 150, lo.y() - 150, table_z - 20),
                               Vec3(hi.x() + 150, hi.y() + 150, table_z), kTableReflectance));
  sim::Scene scene;
  scene.workpiece = sim::MakeUnion(std::move(parts));
  return scene;
}

Pose3 McsFromProbe(const Vec3& centre_mcs, double radius_mm, const ViewPlan& plan) {
  // From the sphere towards the probe: tilted from +z towards the azimuth.
  const Vec3 up(std::sin(plan.tilt_rad) * std::cos(plan.azimuth_rad),
                std::sin(plan.tilt_rad) * std::sin(plan.azimuth_rad), std::cos(plan.tilt_rad));
  const Vec3 z = -up;
  // x: the machine's x made perpendicular to the view (the view is never near horizontal), then
  // turned by the spin about the view.
  const Vec3 x0 = (Vec3::UnitX() - Vec3::UnitX().dot(z) * z).normalized();
  const Vec3 x = Eigen::AngleAxisd(plan.spin_rad, z) * x0;
  Pose3 p = Pose3::Identity();
  p.linear() << x, z.cross(x), z;
  p.translation() = centre_mcs - (plan.standoff_mm + radius_mm) * z - plan.offset_mm.x() * x -
                    plan.offset_mm.y() * z.cross(x);
  return p;
}

View RenderView(const ViewChain& chain,
                sim::Scene scene,
                const Vec3& centre_mcs,
                double radius_mm,
                const ViewPlan& plan,
                double exposure,
                std::uint64_t seed) {
  scene.flange_from_probe = chain.true_flange_from_probe;
  sim::Capture capture;
  capture.id = "view";
  // The host puts its (calibrated) probe frame where the plan says, through its own M.
  const Pose3 mcs_from_probe = McsFromProbe(centre_mcs, radius_mm, plan);
  capture.mcs_from_flange = mcs_from_probe * chain.host_flange_from_probe.inverse();
  // It plans the window and the columns with what it knows: the calibrated model and its M.
  sim::Scene planned = scene;
  planned.flange_from_probe = chain.host_flange_from_probe;
  const sim::VirtualProbe planner(*chain.calibrated, planned);
  const auto& cam = chain.calibrated->camera;
  const geometry::Vec2 px = cam.Project(mcs_from_probe.inverse() * centre_mcs);
  sim::SweepOptions o;
  const int side = plan.aoi_px;
  o.aoi = {std::clamp(static_cast<int>(std::lround(px.x())) - side / 2, 0, cam.width_px - side),
           std::clamp(static_cast<int>(std::lround(px.y())) - side / 2, 0, cam.height_px - side),
           side, side};
  planner.ColumnsReaching(capture, o.aoi, &o.first_column, &o.last_column);
  o.column_step = kColumnStep;
  o.seed = seed;
  o.exposure = exposure;
  // The probe renders as built; its firmware knows only the calibrated model.
  const sim::VirtualProbe probe(*chain.as_built, std::move(scene));
  const sim::RenderedCapture frames = probe.Render(capture, o);
  probe_fw::StripeCounts counts;
  const auto cloud = probe_fw::ReconstructSweep(*chain.calibrated, frames.laser,
                                                probe_fw::RowMask::Full(o.aoi), {}, &counts);
  View view;
  view.mcs_from_flange = capture.mcs_from_flange;
  view.planned_centre_in_probe = mcs_from_probe.inverse() * centre_mcs;
  view.points_in_probe.resize(3, static_cast<Eigen::Index>(cloud.size()));
  for (size_t i = 0; i < cloud.size(); ++i)
    view.points_in_probe.col(static_cast<Eigen::Index>(i)) = cloud[i].point_in_probe;
  return view;
}

}  // namespace mlp::verify
