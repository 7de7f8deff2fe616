// The sphere hand-eye on the virtual probe: the reference sphere on a stem above the table,
// rendered at 12 flange poses of a five-axis head, reconstructed by the real firmware, then
// calibrated; M and the centre compared with the scene's truth.

#include "mlp/calib/hand_eye.h"
#include "mlp/calib/recheck.h"
#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <chrono>

#include "hand_eye_fixture.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::calib {
namespace {

constexpr double kTranslationTolMm = 0.002;  // issue 5, 12 poses at nominal noise
constexpr double kRotationTolArcsec = 5.0;
constexpr double kCentreTolMm = 0.002;
constexpr int kAoiPx = 400;        // the central part of the sphere's image (radius ~470 px)
constexpr double kColumnStep = 4;  // every fourth projector column

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

sim::Scene SphereScene(const testing::Truth& truth) {
  sim::Scene s;
  const Vec3 c = truth.centre_mcs;
  const double table_z = c.z() - 60.0;
  s.workpiece = sim::MakeUnion({
      sim::MakeSphere(c, truth.radius_mm, 0.8),
      sim::MakeRevolution(Vec3(c.x(), c.y(), table_z), Vec3::UnitZ(), 50.0, 4.0, 4.0, 0.5),
      sim::MakeBox(Vec3(c.x() - 150, c.y() - 150, table_z - 20),
                   Vec3(c.x() + 150, c.y() + 150, table_z), 0.4),
  });
  s.flange_from_probe = truth.flange_from_probe;
  return s;
}

SphereCapture Capture(const sim::VirtualProbe& probe,
                      const Pose3& h,
                      int index,
                      const testing::Truth& planned = testing::DefaultTruth()) {
  sim::Capture c;
  c.id = "sphere-" + std::to_string(index);
  c.mcs_from_flange = h;
  const auto& cam = probe.model().camera;
  // The AOI around where the sphere centre projects (by the calibration the machine knows).
  const geometry::Vec2 centre_px = cam.Project(testing::CentreInProbe(planned, h));
  sim::SweepOptions o;
  o.aoi = {std::clamp(static_cast<int>(centre_px.x()) - kAoiPx / 2, 0, cam.width_px - kAoiPx),
           std::clamp(static_cast<int>(centre_px.y()) - kAoiPx / 2, 0, cam.height_px - kAoiPx),
           kAoiPx, kAoiPx};
  probe.ColumnsReaching(c, o.aoi, &o.first_column, &o.last_column);
  o.column_step = kColumnStep;
  o.seed = static_cast<std::uint64_t>(100 + index);
  const sim::RenderedCapture r = probe.Render(c, o);
  probe_fw::StripeCounts counts;
  const auto cloud = probe_fw::ReconstructSweep(probe.model(), r.laser,
                                                probe_fw::RowMask::Full(o.aoi), {}, &counts);
  SphereCapture out;
  out.id = c.id;
  out.mcs_from_flange = h;
  out.points_in_probe.resize(3, static_cast<Eigen::Index>(cloud.size()));
  for (size_t i = 0; i < cloud.size(); ++i)
    out.points_in_probe.col(static_cast<Eigen::Index>(i)) = cloud[i].point_in_probe;
  return out;
}

TEST(VirtualProbeHandEye, TwelveFiveAxisPosesMeetTheIssueTolerances) {
  const testing::Truth truth = testing::DefaultTruth();
  const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), SphereScene(truth));
  const auto poses = testing::MakePoses(truth, testing::PoseSet::kFiveAxis, 12);
  const auto start = std::chrono::steady_clock::now();
  std::vector<SphereCapture> captures;
  for (size_t i = 0; i < poses.size(); ++i)
    captures.push_back(Capture(probe, poses[i], static_cast<int>(i)));
  const double render_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  HandEyeOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  const HandEyeResult r = SolveSphereHandEye(captures, o);
  int points = 0;
  for (const auto& c : captures) points += static_cast<int>(c.points_in_probe.cols());
  std::printf("rendered and reconstructed 12 captures (%d points) in %.1f s\n", points, render_s);
  const testing::Errors e = testing::ErrorsOf(truth, r, "virtual probe, five-axis");
  for (const auto& w : r.warnings) std::printf("  warning: %s\n", w.c_str());
  EXPECT_LT(e.translation_mm, kTranslationTolMm);
  EXPECT_LT(e.rotation_arcsec, kRotationTolArcsec);
  EXPECT_LT(e.centre_mm, kCentreTolMm);
}

// Issue 25: a probe whose camera/projector calibration is off reads depth k times short (its
// readings' z divided by k after the firmware: the error is applied to the firmware's output,
// not rendered by an as-built probe, which issue 16 adds). With the depth scale estimated, the
// hand-eye finds k to 0.1 % and says so, and M and the centre still meet the issue-5
// tolerances; the rigid solution cannot (it absorbs the scale into M and the centre).
constexpr double kDepthScaleTol = 0.001;

TEST(VirtualProbeHandEye, ADepthScaleErrorIsFoundAndSaidNotAbsorbed) {
  const testing::Truth truth = testing::DefaultTruth();
  const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), SphereScene(truth));
  const auto poses = testing::MakePoses(truth, testing::PoseSet::kFiveAxis, 12);
  std::vector<SphereCapture> nominal;
  for (size_t i = 0; i < poses.size(); ++i)
    nominal.push_back(Capture(probe, poses[i], static_cast<int>(i)));
  for (double k : {1.02, 0.985}) {
    std::vector<SphereCapture> captures = nominal;
    for (auto& c : captures) c.points_in_probe.row(2) /= k;
    HandEyeOptions o;
    o.sphere_radius_mm = truth.radius_mm;
    o.leave_one_out = false;  // the rigid solution is only compared
    const testing::Errors rigid = testing::ErrorsOf(truth, SolveSphereHandEye(captures, o),
                                                    "virtual probe, depth scaled, rigid");
    o.sensor.scale_z = true;
    o.leave_one_out = k > 1.0;  // once: each held-out solve costs as much as the solution
    const auto start = std::chrono::steady_clock::now();
    const HandEyeResult r = SolveSphereHandEye(captures, o);
    std::printf("  solved in %.1f s (%d iterations)\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                r.iterations);
    const testing::Errors e = testing::ErrorsOf(truth, r, "virtual probe, depth scale estimated");
    std::printf("  true depth scale %.4f, found %.5f +- %.5f; leave-one-out centre error %.2f um\n",
                k, r.sensor.scale.z(), r.sensor.scale_std.z(),
                r.leave_one_out.centre_error_rms_mm * 1e3);
    for (const auto& f : r.sensor.findings) std::printf("  finding: %s\n", f.c_str());
    EXPECT_NEAR(r.sensor.scale.z(), k, kDepthScaleTol);
    ASSERT_EQ(r.sensor.findings.size(), 1u);
    EXPECT_NE(r.sensor.findings[0].find("depth (z) scale"), std::string::npos);
    EXPECT_LT(e.translation_mm, kTranslationTolMm);
    EXPECT_LT(e.rotation_arcsec, kRotationTolArcsec);
    EXPECT_LT(e.centre_mm, kCentreTolMm);
    EXPECT_GT(rigid.translation_mm + rigid.centre_mm, 10.0 * kTranslationTolMm);
  }
}

TEST(VirtualProbeRecheck, ADepthScaleChangeIsReportedAsSuch) {
  const testing::Truth truth = testing::DefaultTruth();
  const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), SphereScene(truth));
  const auto poses = testing::MakePoses(truth, testing::PoseSet::kFiveAxis, 4);
  constexpr double kScale = 1.015;
  std::vector<RecheckCapture> captures;
  for (size_t i = 0; i < poses.size(); ++i) {
    const SphereCapture c = Capture(probe, poses[i], static_cast<int>(i));
    captures.push_back({c.id, c.mcs_from_flange, c.points_in_probe});
    captures.back().points_in_probe.row(2) /= kScale;
  }
  RecheckOptions o;
  o.sphere_radius_mm = truth.radius_mm;
  o.original_flange_from_probe = truth.flange_from_probe;
  o.original_centre_mcs = truth.centre_mcs;
  const RecheckResult r = Recheck(captures, o);
  std::printf("virtual recheck, depth scale %.3f: found %.5f +- %.5f, offset %.2f um; %s\n", kScale,
              r.depth_scale, r.depth_scale_std, r.offset_in_flange_mm.norm() * 1e3,
              r.reason.c_str());
  EXPECT_NEAR(r.depth_scale, kScale, kDepthScaleTol);
  EXPECT_TRUE(r.full_calibration_required);
  EXPECT_NE(r.reason.find("depth scale"), std::string::npos) << r.reason;
  EXPECT_LT(r.offset_in_flange_mm.norm(), kTranslationTolMm);  // the mount did not move
}

TEST(VirtualProbeRecheck, ReseatedProbeAndRemountedSphereAreRecovered) {
  const testing::Truth original = testing::DefaultTruth();
  testing::Truth now = original;  // the probe re-seated and the sphere re-mounted
  now.flange_from_probe.linear() =
      testing::Rot(2.5e-4, Vec3(0.3, -1.0, 0.5)) * now.flange_from_probe.linear();
  now.flange_from_probe.translation() += Vec3(0.04, -0.06, 0.025);
  now.centre_mcs += Vec3(-0.12, 0.08, 0.03);
  const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), SphereScene(now));
  const auto poses = testing::MakePoses(original, testing::PoseSet::kFiveAxis, 6);
  std::vector<RecheckCapture> captures;
  for (size_t i = 0; i < poses.size(); ++i) {
    const SphereCapture c = Capture(probe, poses[i], static_cast<int>(i), original);
    captures.push_back({c.id, c.mcs_from_flange, c.points_in_probe});
  }
  RecheckOptions o;
  o.sphere_radius_mm = original.radius_mm;
  o.original_flange_from_probe = original.flange_from_probe;
  o.original_centre_mcs = original.centre_mcs;
  o.sphere_moved = true;
  const RecheckResult r = Recheck(captures, o);
  const double offset_err =
      (r.flange_from_probe.translation() - now.flange_from_probe.translation()).norm();
  const double rot_err = testing::Arcsec(now.flange_from_probe.inverse() * r.flange_from_probe);
  const double centre_err = (r.centre_mcs - now.centre_mcs).norm();
  std::printf(
      "virtual recheck: offset error %.3f um, rotation error %.2f arcsec, centre error "
      "%.3f um, residual after %.3f um, apparent radius change %.3f um\n",
      offset_err * 1e3, rot_err, centre_err * 1e3, r.residual_after_rms_mm * 1e3,
      r.apparent_radius_change_mm * 1e3);
  EXPECT_LT(offset_err, kTranslationTolMm);
  EXPECT_LT(rot_err, kRotationTolArcsec);
  EXPECT_LT(centre_err, kCentreTolMm);
  EXPECT_FALSE(r.full_calibration_required) << r.reason;
}

}  // namespace
}  // namespace mlp::calib
