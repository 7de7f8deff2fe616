// The edge from LED-frame sights (jobs/edge.h) on exact synthetic views: the sight planes of a
// known edge met with its face give the edge back; bad views are refused by name; the offset
// against a nominal has the sign the compensation needs; the plan aims its views at the edge.

#include "mlp/features/edge.h"

#include "mlp/features/plan.h"

#include <cmath>

#include <gtest/gtest.h>

namespace mlp::features {
namespace {

using geometry::Vec3;

constexpr double kExactMm = 1e-9;  // exact geometry: rounding only
const double kAngle = 0.2;         // the edge's direction in the face [rad]
const Vec3 kAlong(std::cos(kAngle), std::sin(kAngle), 0.0);
const Vec3 kIntoMaterial(-std::sin(kAngle), std::cos(kAngle), 0.0);  // left of the edge
const Vec3 kOnEdge(5.0, 3.0, 0.0);

// A camera 120 mm above the edge at `s` along it, seeing 1.5 mm of it either side.
EdgeView ViewAt(double s, const std::string& id, const Vec3& camera_shift = Vec3::Zero()) {
  EdgeView v;
  v.capture_id = id;
  const Vec3 at = kOnEdge + s * kAlong;
  v.camera_mcs = at + Vec3(0, 0, 120) + camera_shift;
  const Vec3 p = at - 1.5 * kAlong, q = at + 1.5 * kAlong;
  v.first_ray_mcs = (p - v.camera_mcs).normalized();
  v.last_ray_mcs = (q - v.camera_mcs).normalized();
  v.normal_mcs = v.first_ray_mcs.cross(v.last_ray_mcs).normalized();
  if (v.normal_mcs.dot(at + kIntoMaterial - v.camera_mcs) < 0) v.normal_mcs = -v.normal_mcs;
  v.points = 100;
  v.rms_px = 0.1;
  return v;
}

const geometry::Plane kFace{Vec3::Zero(), Vec3::UnitZ()};

TEST(Edge, TwoSightsMetWithTheFaceGiveTheEdgeBack) {
  const EdgeMeasurement m =
      MeasureEdge({ViewAt(-40, "a", Vec3(3, -2, 5)), ViewAt(40, "b", Vec3(-1, 4, -6))}, kFace);
  EXPECT_NEAR((m.line_mcs.direction - kAlong).norm(), 0.0, kExactMm);
  const Vec3 d = m.line_mcs.point - kOnEdge;
  EXPECT_NEAR((d - d.dot(kAlong) * kAlong).norm(), 0.0, kExactMm);
  EXPECT_NEAR((m.into_material_mcs - kIntoMaterial).norm(), 0.0, kExactMm);
  EXPECT_NEAR(m.span_mm, 83.0, kExactMm);
  EXPECT_NEAR(m.straightness_mm, 0.0, kExactMm);
  EXPECT_EQ(m.views, 2);
  EXPECT_EQ(m.points, 200);
  // One view: its segment, oriented the same way (the material on +Y).
  const EdgeMeasurement one = MeasureEdge({ViewAt(0, "c")}, kFace);
  EXPECT_NEAR((one.line_mcs.direction - kAlong).norm(), 0.0, kExactMm);
  EXPECT_NEAR(one.span_mm, 3.0, kExactMm);
}

TEST(Edge, AgainstTheNominalTheOffsetIsPositiveWhereTheWallIsProud) {
  EdgeNominal n;
  n.face.normal_mcs = Vec3::UnitZ();
  n.wall_normal_mcs = -kIntoMaterial;
  n.point_mcs = kOnEdge + 0.020 * kIntoMaterial + 7.0 * kAlong;  // the wall 20 um proud of it
  n.length_mm = 80;
  const EdgeMeasurement m = MeasureEdge({ViewAt(-40, "a"), ViewAt(40, "b")}, kFace);
  const EdgeDeviation dev = CompareEdge(m, n);
  EXPECT_NEAR(dev.offset_mm, 0.020, kExactMm);
  EXPECT_NEAR(dev.angle_deg, 0.0, 1e-7);
  EXPECT_NEAR((dev.found_mcs - (kOnEdge + 7.0 * kAlong)).norm(), 0.0, kExactMm);
  // The nominal turned 0.1 deg in the face: the edge reads -0.1 deg against it.
  n.wall_normal_mcs = Eigen::AngleAxisd(0.1 * M_PI / 180, Vec3::UnitZ()) * n.wall_normal_mcs;
  EXPECT_NEAR(CompareEdge(m, n).angle_deg, -0.1, 1e-9);
}

// The u each view carries (100 points at 0.1 px over 3 mm: 0.1 / sqrt(100) px of 0.03 mm
// across, 0.1 sqrt(12) / 100^1.5 rad in turn), through the line's fit: one view's segment at
// its middle gives its own across u; two views 80 mm apart give half the root of two of it at
// their middle and their turn through the lever of 80 mm.
TEST(Edge, TheUncertaintyIsTheViewsCarriedThroughTheLine) {
  EdgeNominal n;
  n.face.normal_mcs = Vec3::UnitZ();
  n.point_mcs = kOnEdge;
  n.wall_normal_mcs = -kIntoMaterial;
  const double across_mm = 0.1 / std::sqrt(100.0) * 3.0 / 100.0;
  const EdgeDeviation one = CompareEdge(MeasureEdge({ViewAt(0, "c")}, kFace), n);
  EXPECT_NEAR(one.offset_u_mm, across_mm, kExactMm);
  EXPECT_NEAR(one.angle_u_deg, 0.1 * std::sqrt(12.0) / 1000.0 * 180.0 / M_PI, kExactMm);
  const EdgeDeviation two = CompareEdge(MeasureEdge({ViewAt(-40, "a"), ViewAt(40, "b")}, kFace), n);
  EXPECT_NEAR(two.offset_u_mm, across_mm / std::sqrt(2.0), 1e-3 * across_mm);
  EXPECT_LT(two.angle_u_deg, one.angle_u_deg);
  // A face height uncertainty moves nothing seen straight down, and an oblique view's segment.
  EXPECT_NEAR(CompareEdge(MeasureEdge({ViewAt(0, "c")}, kFace), n, 0.01).offset_u_mm,
              one.offset_u_mm, kExactMm);
  const EdgeDeviation tilted =
      CompareEdge(MeasureEdge({ViewAt(0, "d", Vec3(-30 * kIntoMaterial))}, kFace), n, 0.01);
  EXPECT_NEAR(tilted.offset_u_mm, std::hypot(one.offset_u_mm, 0.01 * 30.0 / 120.0), 1e-4);
}

TEST(Edge, BadViewsAreRefusedByName) {
  const auto refused = [](const std::vector<EdgeView>& views, const geometry::Plane& face,
                          const std::string& why) {
    try {
      MeasureEdge(views, face);
      ADD_FAILURE() << "measured: " << why;
    } catch (const FeatureError& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
    }
  };
  refused({}, kFace, "no capture with an edge");
  EdgeView flipped = ViewAt(40, "b");
  flipped.normal_mcs = -flipped.normal_mcs;  // the lit face on the other side
  refused({ViewAt(-40, "a"), flipped}, kFace, "capture b sees the lit face on the other side");
  // A face the rays graze, and one behind the camera.
  refused({ViewAt(0, "c")}, {Vec3::Zero(), Vec3::UnitX()}, "graze");
  refused({ViewAt(0, "c")}, {Vec3(0, 0, 200), Vec3::UnitZ()}, "behind the camera");
}

TEST(Edge, ThePlanAimsItsViewsAtTheEdgeWithItsHint) {
  EdgeNominal n;
  n.face.point_mcs = kOnEdge;
  n.face.normal_mcs = Vec3::UnitZ();
  n.point_mcs = kOnEdge;
  n.wall_normal_mcs = -kIntoMaterial;
  n.length_mm = 80;
  const std::vector<ViewTarget> views = EdgeViews("front", n, PlanOptions{});
  ASSERT_EQ(views.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const Vec3 at = kOnEdge + (k == 0 ? -40.0 : 40.0) * kAlong;
    ASSERT_TRUE(views[k].edge_hint_mcs);
    EXPECT_NEAR((*views[k].edge_hint_mcs - at).norm(), 0.0, kExactMm);
    EXPECT_NEAR((views[k].mcs_from_camera * Vec3(0, 0, 120) - at).norm(), 0.0, kExactMm);
    EXPECT_NEAR((views[k].mcs_from_camera.linear().col(0) - kAlong).norm(), 0.0, kExactMm);
  }
  EXPECT_EQ(views[0].id, "front_1");
  n.wall_normal_mcs = Vec3::UnitZ();  // along the face's normal: no edge
  EXPECT_THROW(EdgeViews("front", n, PlanOptions{}), FeatureError);
}

}  // namespace
}  // namespace mlp::features
