// The plan job in-process (issue 53): a feature's nominal -> its views (jobs::FeatureViews) ->
// the captures for the reference probe (features::PlanCaptures), as the service's plan job runs
// them, checked by the geometry they must have: H M the view's camera frame, the patch's image
// inside the capture's AOI; a face is reachable by a 3-axis machine (its spindle pointing down,
// H = T Rz Rx(180 deg) as LinuxCNC's M101 and the virtual scenes have it), a bore's walls need a
// tilt and the plan says how much.

#include "mlp/features/plan.h"

#include "mlp/jobs/measure_feature.h"
#include "mlp/probe_fw/probe_model.h"

#include <string>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

using geometry::Pose3;
using geometry::Vec3;
constexpr double kPoseTol = 1e-9;  // H M is the view's camera frame, to rounding

const probe_fw::ProbeModel& Probe() {
  static const probe_fw::ProbeModel probe =
      probe_fw::LoadProbeModel(test::SourceDir() + "/samples/probes/reference_probe.json");
  return probe;
}

// A probe mounted 150 mm below the flange, turned 90 deg about the spindle, its camera looking
// along the spindle (a face square on needs no tilt).
Pose3 FlangeFromProbe() {
  Pose3 m = Pose3::Identity();
  m.linear() = Eigen::AngleAxisd(M_PI / 2, Vec3::UnitZ()).toRotationMatrix();
  m.translation() = Vec3(3, -2, 150);
  return m;
}

// Every capture: the camera (P = H M) at the standoff from its view's patch centre on its
// optical axis, every patch point's pixel inside the AOI.
void ExpectCapturesSeeTheirPatches(const std::vector<features::ViewTarget>& views,
                                   const std::vector<features::PlannedCapture>& plan,
                                   const features::PlanOptions& o) {
  ASSERT_EQ(plan.size(), views.size());
  for (size_t i = 0; i < plan.size(); ++i) {
    const features::PlannedCapture& c = plan[i];
    const Pose3 mcs_from_camera = c.mcs_from_flange * FlangeFromProbe();
    EXPECT_LT((mcs_from_camera.matrix() - views[i].mcs_from_camera.matrix()).norm(), kPoseTol)
        << c.id;
    for (Eigen::Index k = 0; k < views[i].patch_mcs.cols(); ++k) {
      const Vec3 p = mcs_from_camera.inverse() * Vec3(views[i].patch_mcs.col(k));
      ASSERT_GT(p.z(), 0) << c.id;
      const geometry::Vec2 px = Probe().camera.Project(p);
      EXPECT_GE(px.x(), c.aoi.x0) << c.id;
      EXPECT_GE(px.y(), c.aoi.y0) << c.id;
      EXPECT_LE(px.x(), c.aoi.x0 + c.aoi.width) << c.id;
      EXPECT_LE(px.y(), c.aoi.y0 + c.aoi.height) << c.id;
    }
    EXPECT_LT(c.first_column, c.last_column) << c.id;
    EXPECT_EQ(c.column_step, o.column_step) << c.id;
  }
}

TEST(PlanJob, AFaceIsSeenSquareOnFromTheWorkingDistanceByAThreeAxisMachine) {
  features::PlaneNominal n;
  n.point_mcs = Vec3(40, 25, -5);
  n.normal_mcs = Vec3::UnitZ();
  const features::PlanOptions o;
  const auto views = FeatureViews({"face", n}, o);
  const auto plan = features::PlanCaptures(views, Probe(), FlangeFromProbe(), o);
  ExpectCapturesSeeTheirPatches(views, plan, o);
  EXPECT_EQ(features::CheckReachable(plan), "");
}

TEST(PlanJob, ABoresWallsAreSeenFromFourSidesAndNeedATilt) {
  features::BoreNominal n;
  n.top_centre_mcs = Vec3(40, 25, 0);
  n.diameter_mm = 60.0;
  n.depth_mm = 14.0;
  features::PlanOptions o;
  o.views_per_circle = 4;
  const auto views = FeatureViews({"bore", n}, o);
  const auto plan = features::PlanCaptures(views, Probe(), FlangeFromProbe(), o);
  ASSERT_EQ(plan.size(), 4u);
  ExpectCapturesSeeTheirPatches(views, plan, o);
  // Each wall's view comes from across the bore, tilted wall_tilt_deg from its axis.
  for (const features::ViewTarget& v : views) {
    const Vec3 look = v.mcs_from_camera.linear().col(2);
    EXPECT_NEAR(std::acos(-look.z()) * 180 / M_PI, o.wall_tilt_deg, 1e-9) << v.id;
  }
  const std::string tilt = features::CheckReachable(plan);
  EXPECT_NE(tilt.find("tilted 30.00 deg"), std::string::npos) << tilt;
}

TEST(PlanJob, AViewOutsideTheSensorIsRefusedByName) {
  features::PlaneNominal n;
  n.point_mcs = Vec3(0, 0, 0);
  n.normal_mcs = Vec3::UnitZ();
  features::PlanOptions o;
  o.patch_mm = 500.0;  // a patch no sensor window holds at 120 mm
  const auto views = FeatureViews({"face", n}, o);
  EXPECT_THROW(features::PlanCaptures(views, Probe(), FlangeFromProbe(), o),
               features::FeatureError);
}

}  // namespace
}  // namespace mlp::jobs
