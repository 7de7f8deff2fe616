// The firmware against the physics of real parts (issue 16, parts 2-3): a bore in ground steel
// whose walls reflect the stripe onto each other, and laser speckle with a grain. The renderer
// knows the truth; the firmware triangulates with the model only.

#include "mlp/geometry/fit.h"
#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <cmath>
#include <cstdio>

#include "scenes.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

using probe_fw::CloudPoint;

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

using testing::WallCapture;

// Distance [mm] of a point to the true surface of a through bore of radius R in the block
// [-50, 50]^2 x [-30, 0]: the wall, the top face or the bottom face, whichever is nearest.
double ToBoreBlock(const Vec3& q, double radius) {
  const double r = q.head<2>().norm();
  double d = INFINITY;
  if (q.z() <= 0.0 && q.z() >= -30.0) d = std::abs(r - radius);
  if (r >= radius) d = std::min({d, std::abs(q.z()), std::abs(q.z() + 30.0)});
  return std::min(d, std::hypot(r - radius, std::min(std::abs(q.z()), std::abs(q.z() + 30.0))));
}

struct BoreResult {
  size_t points = 0, wall_points = 0, beyond = 0, ghost_splats = 0;
  double worst_mm = 0.0, diameter_error_mm = 0.0, rms_mm = 0.0;
  std::uint64_t indirect = 0;
};

BoreResult MeasureBore(const probe_fw::ProbeModel& model,
                       double radius,
                       bool interreflections,
                       double exposure,
                       const Gloss& finish = Gloss{0.55, 0.12}) {
  constexpr double kBeyondMm = 0.050;
  Scene scene;
  scene.workpiece =
      MakeFinish(MakeDifference(MakeBox({-50, -50, -30}, {50, 50, 0}, 0.5),
                                {MakeRevolution({0, 0, -31}, {0, 0, 1}, 32, radius, radius, 0.5)}),
                 finish, 0.08);
  for (int k = 0; k < 4; ++k)
    scene.captures.push_back(WallCapture(k * M_PI / 2, radius, "wall" + std::to_string(k)));
  const VirtualProbe probe(model, scene);
  BoreResult res;
  std::vector<Vec3> wall_points;
  for (const Capture& c : probe.scene().captures) {
    SweepOptions o = testing::WallSweep(probe, c);
    o.interreflections = interreflections;
    o.exposure = exposure;
    const RenderedCapture r = probe.Render(c, o);
    probe_fw::StripeCounts counts;
    const auto cloud = probe_fw::ReconstructSweep(probe.model(), r.laser,
                                                  probe_fw::RowMask::Full(o.aoi), {}, &counts);
    res.indirect += counts.indirect;
    const Pose3 mcs_from_probe = probe.McsFromProbe(c);
    for (const CloudPoint& p : cloud) {
      const Vec3 q = mcs_from_probe * p.point_in_probe;
      const double d = ToBoreBlock(q, radius);
      ++res.points;
      res.worst_mm = std::max(res.worst_mm, d);
      res.beyond += d > kBeyondMm;
      if (std::abs(q.head<2>().norm() - radius) < 0.5 && q.z() < -1.0 && q.z() > -29.0)
        wall_points.push_back(q);
    }
    res.ghost_splats = r.ghosts.size();
  }
  res.wall_points = wall_points.size();
  if (wall_points.size() > 100) {
    geometry::Points3 pts(3, static_cast<Eigen::Index>(wall_points.size()));
    for (size_t i = 0; i < wall_points.size(); ++i) pts.col(Eigen::Index(i)) = wall_points[i];
    const auto fit = geometry::FitCylinder(pts);
    res.rms_mm = fit.stats.rms;
    res.diameter_error_mm = 2.0 * fit.shape.radius - 2.0 * radius;
  }
  return res;
}

// Issue 16, done means: on ground steel with inter-reflections in a 20 / 40 / 60 mm bore, no
// point more than 50 um from the true surface and the diameter within 5 um. Exposure 8x the
// matt design's: the ground face returns about a tenth of a white matt face's light.
TEST(RealMetal, GroundSteelBoreWithInterreflections) {
  constexpr double kDiameterMm = 0.005;
  constexpr double kExposure = 8.0;
  const probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReference);
  for (double diameter : {20.0, 40.0, 60.0}) {
    SCOPED_TRACE(diameter);
    const BoreResult r = MeasureBore(model, diameter / 2, true, kExposure);
    std::printf(
        "ground steel bore %.0f mm: %zu points (%zu ghost splats per view), %zu beyond 50 "
        "um (worst %.1f um), diameter error %.2f um, wall rms %.2f um\n",
        diameter, r.points, r.ghost_splats, r.beyond, r.worst_mm * 1e3, r.diameter_error_mm * 1e3,
        r.rms_mm * 1e3);
    EXPECT_GT(r.ghost_splats, 1000u);
    EXPECT_GT(r.wall_points, 40000u);
    EXPECT_EQ(r.beyond, 0u);
    EXPECT_LT(std::abs(r.diameter_error_mm), kDiameterMm);
  }
}

// A polished or ground wall standing on the measured floor, facing the projector: the sheet of
// the columns that meet the wall is reflected onto the floor beside it, a second stripe moving
// the other way through the sweep (a mirror turns the baseline round). No point of it may
// reach the cloud.
struct StepResult {
  size_t points = 0, beyond = 0;
  double worst_mm = 0.0;
  double beyond_farthest_from_corner_mm = 0.0;  ///< of the points beyond 50 um
  std::uint64_t indirect = 0;
  size_t ghost_splats = 0;
};

StepResult MeasureStep(const Gloss& wall_finish, double exposure, bool inter = true) {
  constexpr double kWallXmm = -4.0, kBeyondMm = 0.050;
  probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReference);
  Scene scene = testing::FlatScene(0.6, 50.0);
  scene.workpiece =
      MakeUnion({scene.workpiece,
                 MakeFinish(MakeBox({-50, -50, -30}, {kWallXmm, 50, 30}, 0.5), wall_finish, 0.08)});
  const VirtualProbe probe(model, scene);
  const Capture& c = scene.captures[0];
  const Pose3 mcs_from_probe = probe.McsFromProbe(c);
  const geometry::Vec2 foot =
      model.camera.Project(mcs_from_probe.inverse() * Vec3(kWallXmm, 0.0, 0.0));
  SweepOptions o;
  o.aoi = {int(foot.x()) - 60, int(foot.y()) - 80, 260, 160};
  probe.ColumnsReaching(c, o.aoi, &o.first_column, &o.last_column, 9);
  o.column_step = 2.0;
  o.seed = 17;
  o.exposure = exposure;
  o.interreflections = inter;
  const RenderedCapture r = probe.Render(c, o);
  probe_fw::StripeCounts counts;
  const auto cloud =
      probe_fw::ReconstructSweep(model, r.laser, probe_fw::RowMask::Full(o.aoi), {}, &counts);
  StepResult res;
  res.ghost_splats = r.ghosts.size();
  res.indirect = counts.indirect;
  for (const CloudPoint& p : cloud) {
    const Vec3 q = mcs_from_probe * p.point_in_probe;
    // Nearest true surface: the floor (z = 0, x > wall), the wall (x = wall, z > 0) or its top.
    double d = q.x() >= kWallXmm ? std::abs(q.z()) : INFINITY;
    if (q.z() >= 0.0 && q.z() <= 30.0) d = std::min(d, std::abs(q.x() - kWallXmm));
    if (q.x() <= kWallXmm) d = std::min(d, std::abs(q.z() - 30.0));
    d = std::min(d, std::hypot(q.x() - kWallXmm, q.z()));
    ++res.points;
    res.worst_mm = std::max(res.worst_mm, d);
    if (d <= kBeyondMm) continue;
    ++res.beyond;
    res.beyond_farthest_from_corner_mm =
        std::max(res.beyond_farthest_from_corner_mm, std::hypot(q.x() - kWallXmm, q.z()));
  }
  return res;
}

// Issue 16 part 3: no ghost point reaches the cloud. A polished and a honed wall send sharp
// ghosts, which the sweep must reject (the firmware counts them); a ground wall's broad lobe
// lights the floor beside the inner corner, where its light merges with the stripe's: points
// there are biased, not ghosts, and the test bounds where they lie (docs/PROBE.md states it).
TEST(RealMetal, ReflectionsOffAWallBesideTheFloor) {
  constexpr double kCornerBandMm = 0.3;  // ground wall: biased points lie this near the corner
  struct Case {
    const char* name;
    Gloss finish;
  };
  for (const Case& c : {Case{"polished", Gloss{0.9, 0.005}}, Case{"honed", Gloss{0.55, 0.03}},
                        Case{"ground", Gloss{0.55, 0.12}}, Case{"matt", Gloss{}}}) {
    SCOPED_TRACE(c.name);
    const StepResult r = MeasureStep(c.finish, 1.0);
    std::printf(
        "%s wall: %zu ghost splats, %zu points, %zu beyond 50 um (worst %.1f um, all "
        "within %.3f mm of the corner), %lu indirect rejected\n",
        c.name, r.ghost_splats, r.points, r.beyond, r.worst_mm * 1e3,
        r.beyond_farthest_from_corner_mm, static_cast<unsigned long>(r.indirect));
    EXPECT_GT(r.points, 7000u);
    if (c.finish.specular_f0 > 0.0) {
      EXPECT_GT(r.ghost_splats, 100000u);
    }
    if (c.finish.roughness < 0.05) {
      EXPECT_EQ(r.beyond, 0u);
      EXPECT_GT(r.indirect, 500u);  // the ghosts were in the frames, and were told
    } else {
      EXPECT_LT(r.beyond_farthest_from_corner_mm, kCornerBandMm);
    }
  }
}

// Issue 16, done means: speckle of contrast 0.3 with grains of 1.5 px (f/4.7 at 450 nm, 3.45 um
// pixels) on a matt face: the firmware's per-point scatter within 1.5x Dorsch's limit for that
// geometry (scatter as displacement along the light, Dorsch's dz, at the same points), clouds
// within 10 um RMS; without smoothing and with the grain's smoothing (half its diameter).
TEST(RealMetal, SpeckleAgainstTheDorschLimit) {
  probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReference);
  model.camera.f_number =
      1.5 / (2.44 * model.laser.wavelength_nm * 1e-6 / model.camera.pixel_pitch_mm);
  model.noise.speckle_contrast = 0.3;
  const Scene scene = testing::FlatScene(0.6, 50.0);
  const VirtualProbe probe(model, scene);
  const Capture& c = scene.captures[0];
  SweepOptions o;
  o.aoi = {924, 668, 200, 200};
  o.first_column = 470.0, o.last_column = 560.0, o.column_step = 2.0;
  o.seed = 42;
  const RenderedCapture r = probe.Render(c, o);
  const Pose3 mcs_from_probe = probe.McsFromProbe(c);
  const Vec3 normal_probe = mcs_from_probe.linear().transpose() * Vec3::UnitZ();
  constexpr double kDorschFactor = 1.5, kCloudRmsMm = 0.010;
  for (double sigma : {0.0, 0.75}) {
    probe_fw::StripeOptions so;
    so.speckle_sigma_px = sigma;
    probe_fw::StripeCounts counts;
    const auto cloud =
        probe_fw::ReconstructSweep(model, r.laser, probe_fw::RowMask::Full(o.aoi), so, &counts);
    double ss_normal = 0, ss_light = 0, dorsch = 0;
    for (const CloudPoint& p : cloud) {
      const Vec3 q = mcs_from_probe * p.point_in_probe;
      const Vec3 light = (p.point_in_probe - model.projector.Center()).normalized();
      const Vec3 to_camera = -p.point_in_probe.normalized();
      ss_normal += q.z() * q.z();
      const double along = q.z() / std::abs(normal_probe.dot(light));
      ss_light += along * along;
      dorsch += 0.3 * model.laser.wavelength_nm * 1e-6 /
                (2 * M_PI * model.camera.ApertureSinAt(p.point_in_probe.norm()) *
                 to_camera.cross(-light).norm());
    }
    const double n = double(cloud.size());
    std::printf(
        "smoothing %.2f px: %zu points, %.2f um RMS to the plane, along the light %.2f um, "
        "Dorsch %.2f um (ratio %.2f)\n",
        sigma, cloud.size(), std::sqrt(ss_normal / n) * 1e3, std::sqrt(ss_light / n) * 1e3,
        dorsch / n * 1e3, std::sqrt(ss_light / n) / (dorsch / n));
    EXPECT_GT(cloud.size(), 8000u);
    EXPECT_LT(std::sqrt(ss_light / n), kDorschFactor * dorsch / n);
    EXPECT_LT(std::sqrt(ss_normal / n), kCloudRmsMm);
  }
}

}  // namespace
}  // namespace mlp::sim
