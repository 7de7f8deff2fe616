// The probe as built (issue 16, part 1): the as-built file, a window plate no probe model
// describes, a mirror non-linearity and a curved sheet, and frames rendered with them that agree
// with the renderer's own truth, triangulated exactly by a firmware that knows the model and
// visibly wrong from one that does not.

#include "mlp/sim/as_built.h"

#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "scenes.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

using probe_fw::CloudPoint;

const std::string kSample = mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.json";
const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

constexpr double kExactMm = 1e-12;
constexpr double kExactCols = 1e-9;
// Issue 3's stripe target: the frames' stripe centres against the renderer's truth.
constexpr double kStripeRmsPx = 0.05;
// Issue 3's point target, for a firmware that knows the probe exactly.
constexpr double kPointRmsMm = 0.005;
// What the sample's optics do to a firmware that does not know them, at the field's corner: far
// beyond the point target (the window alone moves a ray there by ~0.1 mm).
constexpr double kVisibleMm = 0.020;
// A stripe on most of the 200 rows of each of the ~48 frames of a sweep over a 200 px window.
constexpr int kMinPoints = 8000;

const AsBuiltProbe& Sample() {
  static const AsBuiltProbe a = LoadAsBuilt(kSample);
  return a;
}

TEST(AsBuilt, TheSampleFileReadsWithItsOptics) {
  const AsBuiltProbe& a = Sample();
  EXPECT_FALSE(a.plain_model);
  EXPECT_EQ(a.model.serial, "MLP-REF-0001");  // the reference probe as one unit was built
  EXPECT_DOUBLE_EQ(a.model.projector.mirror_cubic_cols, 1.5);
  EXPECT_DOUBLE_EQ(a.model.projector.sheet_smile_cols, 0.6);
  EXPECT_DOUBLE_EQ(a.optics.window_thickness_mm, 2.0);
  EXPECT_DOUBLE_EQ(a.optics.window_index, 1.517);
  // A plain probe model file is a probe exactly as modelled.
  const AsBuiltProbe plain = LoadAsBuilt(kReference);
  EXPECT_TRUE(plain.plain_model);
  EXPECT_EQ(plain.optics.window_thickness_mm, 0.0);
}

TEST(AsBuilt, BadFilesAreTypedErrorsNamingTheField) {
  const auto refused = [](const std::string& text, const std::string& words) {
    try {
      ParseAsBuilt(text);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const AsBuiltError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    } catch (const probe_fw::ProbeModelError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  refused("{}", "format");
  refused(R"({"format": "mlprobe-as-built/1"})", "model");
  std::ifstream in(kReference);
  std::stringstream model;
  model << in.rdbuf();
  const std::string head = R"({"format": "mlprobe-as-built/1", "model": )" + model.str();
  refused(head + R"(, "windows": {}})", "did you mean \"window\"");
  refused(head + R"(, "window": {"thickness_mm": 2, "refractive_index": 0.8}})",
          "refractive_index");
  refused(head + R"(, "window": {"thickness_mm": -1, "refractive_index": 1.5}})", "thickness_mm");
  refused(head + R"(, "window": {"thickness_mm": 2, "refractive_index": 1.5,
                                 "normal_in_probe": [1, 0, 0.2]}})",
          "normal_in_probe");
  refused(R"({"format": "mlprobe-as-built/1", "model": {"format": "mlprobe-probe-model/1"}})",
          "serial");
}

// The plate against the textbook: a ray at angle phi to the normal leaves the plate parallel to
// itself, displaced sideways by T sin(phi - phi_r) / cos(phi_r), sin(phi) = n sin(phi_r).
TEST(AsBuilt, TheWindowShiftsEachRayAsSnellSays) {
  AsBuiltOptics o;
  o.window_thickness_mm = 3.0;
  o.window_index = 1.517;
  o.window_normal_in_probe = Vec3(0.05, -0.02, 1.0);
  const Vec3 n = o.window_normal_in_probe.normalized();
  for (const Vec3& raw : {Vec3(0, 0, 1), Vec3(0.2, 0.1, 1), Vec3(-0.3, 0.25, 1), n}) {
    const Vec3 d = raw.normalized();
    const Vec3 shift = o.WindowShift(d);
    const double phi = std::acos(d.dot(n));
    const double phi_r = std::asin(std::sin(phi) / o.window_index);
    const double sideways = o.window_thickness_mm * std::sin(phi - phi_r) / std::cos(phi_r);
    EXPECT_NEAR((shift - shift.dot(d) * d).norm(), sideways, kExactMm);
    EXPECT_NEAR(shift.dot(n), 0.0, kExactMm);  // the emerging ray has crossed the plate
  }
  EXPECT_NEAR(o.WindowShift(n).norm(), 0.0, kExactMm);  // along the normal: no shift
}

TEST(AsBuilt, TheMirrorsCubicIsInvertedExactly) {
  const auto& p = Sample().model.projector;
  for (double u = 0.0; u < p.columns; u += 37.25)
    EXPECT_NEAR(p.CommandedColumn(p.ActualColumn(u)), u, kExactCols);
  EXPECT_NEAR(p.ActualColumn(p.c_px), p.c_px, kExactCols);  // no error at the centre
  EXPECT_NEAR(p.ActualColumn(p.c_px + 0.5 * p.columns) - (p.c_px + 0.5 * p.columns),
              p.mirror_cubic_cols, kExactCols);
}

// A flat face 160 mm square, 120 mm below the probe, slightly tilted: the field's corner too.
Scene FlatScene() { return testing::FlatScene(0.6, 80.0); }

struct Sweep {
  double stripe_rms_px = 0.0;  // frames vs the renderer's truth
  double point_rms_mm = 0.0;   // the firmware's points vs the true face (z = 0 in the MCS)
  int points = 0;
};

// A sweep over `aoi` rendered by `probe`, reconstructed by a firmware that knows `model`.
Sweep SweepOver(const VirtualProbe& probe,
                const probe_fw::ProbeModel& model,
                const probe_fw::Aoi& aoi) {
  const Capture& capture = probe.scene().captures[0];
  SweepOptions o;
  o.aoi = aoi;
  probe.ColumnsReaching(capture, aoi, &o.first_column, &o.last_column);
  o.column_step = 2.0;
  o.seed = 7;
  o.noise = false;
  const RenderedCapture r = probe.Render(capture, o);
  probe_fw::StripeCounts counts;
  const auto cloud = probe_fw::ReconstructSweep(model, r.laser, probe_fw::RowMask::Full(aoi),
                                                probe_fw::StripeOptions{}, &counts);
  Sweep s;
  double stripe_ss = 0.0, point_ss = 0.0;
  int checked = 0;
  const Pose3 mcs_from_probe = probe.McsFromProbe(capture);
  for (size_t i = 0; i < cloud.size(); ++i) {
    const CloudPoint& p = cloud[i];
    const double z = (mcs_from_probe * p.point_in_probe).z();
    point_ss += z * z, ++s.points;
    if (i % 7 != 0 || p.axis != probe_fw::ScanAxis::kRow) continue;  // bisection is costly
    const int x = static_cast<int>(std::lround(p.x_px));
    const auto truth =
        probe.TrueStripeCentre(capture, p.column, static_cast<int>(p.y_px), x - 4, x + 5);
    if (!truth) continue;
    stripe_ss += (p.x_px - *truth) * (p.x_px - *truth), ++checked;
  }
  s.stripe_rms_px = std::sqrt(stripe_ss / std::max(1, checked));
  s.point_rms_mm = std::sqrt(point_ss / std::max(1, s.points));
  std::printf(
      "  AOI at (%d, %d): %d points, stripe %.4f px RMS vs truth (%d checked), "
      "points %.2f um RMS from the face\n",
      aoi.x0, aoi.y0, s.points, s.stripe_rms_px, checked, s.point_rms_mm * 1e3);
  return s;
}

const probe_fw::Aoi kCentre{924, 668, 200, 200};
const probe_fw::Aoi kCorner{1780, 1280, 200, 200};

TEST(AsBuilt, AFirmwareThatKnowsTheProbeExactlyMeetsTheTargets) {
  // The probe as built with everything its model describes (the mirror's cubic and the sheet's
  // smile included) and no window: a firmware that knows that model is as good as with the
  // design.
  AsBuiltProbe exact = Sample();
  exact.optics = AsBuiltOptics{};
  const VirtualProbe probe(exact, FlatScene());
  for (const auto& aoi : {kCentre, kCorner}) {
    const Sweep s = SweepOver(probe, exact.model, aoi);
    EXPECT_GT(s.points, kMinPoints);
    EXPECT_LT(s.stripe_rms_px, kStripeRmsPx);
    EXPECT_LT(s.point_rms_mm, kPointRmsMm);
  }
}

TEST(AsBuilt, FramesFollowTheOpticsAndTheFirmwareSeesTheDifference) {
  // With the window, the mirror's cubic and the curved sheet the frames still agree with the
  // renderer's truth, and a firmware given the as-built camera and projector but a linear
  // mirror, a flat sheet and no window is off by far more than its target: only a calibration
  // can know them.
  const VirtualProbe probe(Sample(), FlatScene());
  probe_fw::ProbeModel flat = Sample().model;
  flat.projector.mirror_cubic_cols = flat.projector.sheet_smile_cols = 0.0;
  const Sweep centre = SweepOver(probe, flat, kCentre);
  const Sweep corner = SweepOver(probe, flat, kCorner);
  EXPECT_LT(centre.stripe_rms_px, kStripeRmsPx);
  EXPECT_LT(corner.stripe_rms_px, kStripeRmsPx);
  EXPECT_GT(corner.point_rms_mm, kVisibleMm);
  EXPECT_GT(corner.point_rms_mm, centre.point_rms_mm);
}

}  // namespace
}  // namespace mlp::sim
