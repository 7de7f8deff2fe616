// ROI extraction on LED frames of the virtual probe: a hole's rim circle against the projected
// true rim, a face mask that keeps off the hole, and the ROI's effect on the cloud.

#include "mlp/probe_fw/roi.h"

#include "mlp/geometry/fit.h"
#include "mlp/probe_fw/roi_spec.h"
#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <cmath>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

using geometry::Vec2;
using probe_fw::Aoi;

// A sharp LED step sampled at pixel centres: each edge point is within +-0.5 px, a circle
// through ~1500 of them within a few hundredths.
constexpr double kCentreTolPx = 0.1;
constexpr double kRadiusTolPx = 0.25;
constexpr double kHoleRadiusMm = 6.0;

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

// A block with a 12 mm through-hole at (10, -5), the probe 120 mm straight above the hole.
VirtualProbe HoleProbe() {
  Scene s;
  s.workpiece = MakeDifference(
      MakeBox({-50, -50, -30}, {50, 50, 0}, 0.6),
      {MakeRevolution({10, -5, -31}, {0, 0, 1}, 32, kHoleRadiusMm, kHoleRadiusMm, 0.6)});
  Capture c;
  c.id = "hole";
  c.mcs_from_flange.linear() = Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix();
  c.mcs_from_flange.translation() = Vec3(10, -5, 120);
  s.captures.push_back(c);
  return VirtualProbe(probe_fw::LoadProbeModel(kReference), s);
}

// The true rim: its 3D circle projected through the camera model, then fitted in the image.
geometry::Circle2 ProjectedRim(const VirtualProbe& probe) {
  const Pose3 probe_from_mcs = probe.McsFromProbe(probe.scene().captures[0]).inverse();
  geometry::Points2 px(2, 720);
  for (int k = 0; k < 720; ++k) {
    const double a = k * M_PI / 360.0;
    const Vec3 rim(10 + kHoleRadiusMm * std::cos(a), -5 + kHoleRadiusMm * std::sin(a), 0.0);
    px.col(k) = probe.model().camera.Project(probe_from_mcs * rim);
  }
  return geometry::FitCircle2(px).shape;
}

constexpr Aoi kAoi{624, 368, 800, 800};

TEST(Roi, HoleRimMatchesTheProjectedTrueRim) {
  const VirtualProbe probe = HoleProbe();
  SweepOptions o;
  o.aoi = kAoi;
  o.first_column = o.last_column = 500;  // the LED frame is what matters here
  const RenderedCapture r = probe.Render(probe.scene().captures[0], o);
  const auto hole = probe_fw::FindHole(r.led, {1023.5, 767.5}, 20.0, 600.0);
  ASSERT_TRUE(hole);
  const auto truth = ProjectedRim(probe);
  std::printf("hole: %d edge points, rms %.3f px, centre error %.4f px, radius error %.4f px\n",
              hole->edge_points, hole->rms_px, (hole->center_px - truth.center).norm(),
              hole->radius_px - truth.radius);
  EXPECT_GT(hole->edge_points, 1000);
  EXPECT_LT((hole->center_px - truth.center).norm(), kCentreTolPx);
  EXPECT_NEAR(hole->radius_px, truth.radius, kRadiusTolPx);
  // No hole where there is none: a hint on the plain face far from the rim.
  EXPECT_FALSE(probe_fw::FindHole(r.led, {700.0, 420.0}, 20.0, 60.0));
}

TEST(Roi, FaceMaskStaysOffTheHoleAndHoleMaskHugsTheRim) {
  const VirtualProbe probe = HoleProbe();
  SweepOptions o;
  o.aoi = kAoi;
  o.first_column = o.last_column = 500;
  const RenderedCapture r = probe.Render(probe.scene().captures[0], o);
  const auto truth = ProjectedRim(probe);
  const probe_fw::RowMask face = probe_fw::ParseRoi("face:700,420", kAoi, &r.led);
  const probe_fw::RowMask hole = probe_fw::ParseRoi("hole:1023.5,767.5", kAoi, &r.led);
  ASSERT_GT(face.PixelCount(), 300000u);
  for (int y = 0; y < kAoi.height; ++y) {
    for (const auto& [b, e] : face.rows[static_cast<size_t>(y)]) {
      for (int x = b; x < e; ++x) {
        const double d = (Vec2(kAoi.x0 + x, kAoi.y0 + y) - truth.center).norm();
        ASSERT_GT(d, truth.radius + 5.0) << "face pixel inside the hole at " << x << "," << y;
      }
    }
    for (const auto& [b, e] : hole.rows[static_cast<size_t>(y)]) {
      for (int x = b; x < e; ++x) {
        const double d = (Vec2(kAoi.x0 + x, kAoi.y0 + y) - truth.center).norm();
        ASSERT_GT(d, 0.6 * truth.radius - 1.0);
        ASSERT_LT(d, truth.radius + 21.0);
      }
    }
  }
  EXPECT_THROW(probe_fw::ParseRoi("hole:700,420", kAoi, &r.led), probe_fw::RoiError);
  EXPECT_THROW(probe_fw::ParseRoi("face:1023,767", kAoi, &r.led), probe_fw::RoiError);
  EXPECT_THROW(probe_fw::ParseRoi("hole:1023,767", kAoi, nullptr), probe_fw::RoiError);
}

}  // namespace
}  // namespace mlp::sim

namespace mlp::sim {
namespace {

// The part's edge x = 10 against the dark background, seen from 120 mm straight above a point
// 2 mm inside it; the camera is turned 0.3 rad about its axis so the edge is oblique in the image.
TEST(Roi, LineEdgeMatchesTheProjectedTrueEdge) {
  Scene s;
  s.workpiece = MakeBox({-50, -50, -30}, {10, 50, 0}, 0.6);
  Capture c;
  c.mcs_from_flange.linear() =
      (Eigen::AngleAxisd(M_PI, Vec3::UnitX()) * Eigen::AngleAxisd(0.3, Vec3::UnitZ()))
          .toRotationMatrix();
  c.mcs_from_flange.translation() = Vec3(8, 0, 120);
  s.captures.push_back(c);
  const VirtualProbe probe(probe_fw::LoadProbeModel(kReference), s);
  SweepOptions o;
  o.aoi = {824, 568, 400, 400};
  o.first_column = o.last_column = 500;
  const RenderedCapture r = probe.Render(c, o);
  // The inspection plan's hint: where the nominal edge point (10, 0, 0) should appear.
  const Pose3 probe_from_mcs = probe.McsFromProbe(c).inverse();
  const Vec2 hint = probe.model().camera.Project(probe_from_mcs * Vec3(10, 0, 0));
  const auto edge = probe_fw::FindLineEdge(r.led, hint, 150.0);
  ASSERT_TRUE(edge);
  // The true edge through the camera model, near the hint.
  double worst = 0.0;
  const Vec2 normal(-edge->direction.y(), edge->direction.x());
  for (double y = -2.5; y <= 2.5; y += 0.25) {
    const Vec2 px = probe.model().camera.Project(probe_from_mcs * Vec3(10, y, 0));
    if ((px - hint).norm() > 150.0) continue;
    worst = std::max(worst, std::abs(normal.dot(px - edge->point_px)));
  }
  std::printf("edge: %d points, rms %.3f px, worst distance to the true edge %.3f px\n",
              edge->edge_points, edge->rms_px, worst);
  EXPECT_GT(edge->edge_points, 200);
  EXPECT_LT(worst, kCentreTolPx);
  const probe_fw::RowMask band = probe_fw::ParseRoi(
      "edge:" + std::to_string(hint.x()) + "," + std::to_string(hint.y()), o.aoi, &r.led);
  constexpr double kBandTolPx = 2000.0;  // the band's pixel count, 41 rows wide
  EXPECT_NEAR(static_cast<double>(band.PixelCount()), 41.0 * 400.0 / std::cos(0.3), kBandTolPx);

  // What the capture reports: the plane of rays through the edge, in the probe frame. The true
  // edge lies in it (0.1 px at 120 mm is 2.6 um); the top face (x < 10) is on its lit side; its
  // end rays meet the top face on the edge, within the search radius of the hint.
  const probe_fw::RoiFound found = probe_fw::LocateRoi(
      "edge:" + std::to_string(hint.x()) + "," + std::to_string(hint.y()), o.aoi, &r.led);
  ASSERT_TRUE(found.edge);
  EXPECT_EQ(found.mask.PixelCount(), band.PixelCount());
  const base::EdgeSight sight = probe_fw::SightOfEdge(probe.model().camera, *found.edge);
  constexpr double kSightTolMm = 0.0026;
  double off_plane = 0.0;
  for (double y = -1.5; y <= 1.5; y += 0.25)
    off_plane =
        std::max(off_plane, std::abs(sight.normal_in_probe.dot(probe_from_mcs * Vec3(10, y, 0))));
  std::printf("edge sight: %u points, true edge within %.2f um of its plane\n", sight.points,
              off_plane * 1e3);
  EXPECT_LT(off_plane, kSightTolMm);
  EXPECT_GT(sight.normal_in_probe.dot(probe_from_mcs * Vec3(8, 0, 0)), 0.0);
  EXPECT_LT(sight.normal_in_probe.dot(probe_from_mcs * Vec3(12, 0, 0)), 0.0);
  const Pose3 mcs_from_probe = probe.McsFromProbe(c);
  for (const Vec3& ray : {sight.first_ray_in_probe, sight.last_ray_in_probe}) {
    const Vec3 d = mcs_from_probe.linear() * ray, from = mcs_from_probe.translation();
    const Vec3 on_top = from - d * (from.z() / d.z());
    EXPECT_NEAR(on_top.x(), 10.0, kSightTolMm);
    EXPECT_LT(std::abs(on_top.y()), 61.0 * 120.0 / probe.model().camera.fx_px);  // 60 px search
  }
  EXPECT_EQ(sight.points, found.edge->inliers_px.size());
}

}  // namespace
}  // namespace mlp::sim
