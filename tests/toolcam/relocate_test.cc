// An EDM electrode found again after re-clamping from its own surface texture in reflected
// light (seed 000 example 6), against the virtual reflected-light camera's truth: the texture
// of its side faces recorded at four turns of the C axis, the electrode taken out and clamped
// again turned and shifted, the same turns recorded: the six numbers of the change.

#include "mlp/toolcam/relocate.h"

#include <cmath>
#include <cstdio>
#include <random>

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

const std::string kElectrode = mlp::test::SourceDir() + "/samples/tools/electrode_10x6.json";
constexpr double kShiftTolMm = 0.0005;  // each translation, from 64 patches at 5 um a pixel
constexpr double kTurnTolDeg = 0.002;   // each rotation (7 um over the 10 mm electrode's corner)
constexpr double kRmsMaxUm = 0.5;       // the patches about the fitted motion
constexpr double kRad = M_PI / 180;

// 512 x 512 px at 5 um: a 2.56 mm square of the face square to the view, centred on the
// spindle axis, from 0.3 mm above the electrode's end; reflected light, no lens distortion.
TextureCamera Camera() {
  TextureCamera c;
  c.geometry.width_px = 512, c.geometry.height_px = 512;
  c.geometry.mm_per_px = 0.005;
  c.geometry.axis_u_px = 255.5, c.geometry.tip_v_px = 511.5 + 0.3 / 0.005;
  c.geometry.distortion_k1 = 0, c.geometry.drops_per_frame = 0;
  return c;
}

std::vector<std::vector<std::uint8_t>> Frames(const ToolDescription& e,
                                              const ClampPose& pose,
                                              const std::vector<double>& turns_deg,
                                              unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<std::vector<std::uint8_t>> frames;
  for (double t : turns_deg) frames.push_back(RenderTextureFrame(e, pose, t * kRad, Camera(), rng));
  return frames;
}

ClampPose Reclamped() {
  ClampPose p;
  p.rotation_rad = geometry::Vec3(0.02, -0.03, 0.4) * kRad;  // tilted a little, turned 0.4 deg
  p.translation_mm = geometry::Vec3(0.030, -0.020, 0.015);
  return p;
}

TEST(Relocate, SixDegreesOfFreedomFromTheSurfaceTexture) {
  const ToolDescription e = LoadTool(kElectrode);
  const std::vector<double> turns = {0, 90, 180, 270};
  const auto reference = Frames(e, {}, turns, 81);
  const ClampPose truth = Reclamped();
  auto after = Frames(e, truth, turns, 82);
  // A spot of dielectric dried on the face seen at 90 deg: a bright blot over a patch and a half.
  const TextureCamera c = Camera();
  for (int v = 300; v < 480; ++v)
    for (int u = 40; u < 220; ++u)
      if (std::hypot(u - 130, v - 390) < 90)
        after[1][static_cast<size_t>(v * c.geometry.width_px + u)] = 235;
  const Relocation r = Relocate({reference, turns, c.geometry}, {after, turns, c.geometry}, e);
  std::printf(
      "relocated: rotation (%+.4f, %+.4f, %+.4f) deg (true +0.0200, -0.0300, +0.4000), "
      "translation (%+.2f, %+.2f, %+.2f) um (true +30, -20, +15); tilt %.4f deg; rms %.3f um "
      "over %d patches, %d left out\n",
      r.rotation_deg[0], r.rotation_deg[1], r.rotation_deg[2], r.change.translation_mm.x() * 1e3,
      r.change.translation_mm.y() * 1e3, r.change.translation_mm.z() * 1e3, r.tilt_deg, r.rms_um,
      r.patches, r.left_out);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.rotation_deg[k], truth.rotation_rad[k] / kRad, kTurnTolDeg) << "about " << k;
    EXPECT_NEAR(r.change.translation_mm[k], truth.translation_mm[k], kShiftTolMm) << "along " << k;
  }
  EXPECT_NEAR(r.tilt_deg, std::hypot(0.02, 0.03), kTurnTolDeg);
  EXPECT_LT(r.rms_um, kRmsMaxUm);
  EXPECT_GE(r.patches, 56);
  EXPECT_LE(r.patches, 63) << "the blot's patches were used";
}

// Clamped back exactly: only the sensor's noise differs.
TEST(Relocate, PutBackExactlyIsNoChange) {
  const ToolDescription e = LoadTool(kElectrode);
  const std::vector<double> turns = {0, 120, 240};
  const TextureCamera c = Camera();
  const Relocation r = Relocate({Frames(e, {}, turns, 83), turns, c.geometry},
                                {Frames(e, {}, turns, 84), turns, c.geometry}, e);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(r.rotation_deg[k], 0.0, kTurnTolDeg);
    EXPECT_NEAR(r.change.translation_mm[k], 0.0, kShiftTolMm);
  }
}

TEST(Relocate, WhatCannotBeRelocatedIsRefused) {
  const ToolDescription e = LoadTool(kElectrode);
  const TextureCamera c = Camera();
  // Two opposite turns see the same two directions: the motion along the view is unseen.
  const std::vector<double> opposite = {0, 180};
  const auto a = Frames(e, {}, opposite, 85), b = Frames(e, Reclamped(), opposite, 86);
  EXPECT_THROW(Relocate({a, opposite, c.geometry}, {b, opposite, c.geometry}, e), ToolError);
  // Not the same turns; not an electrode.
  const std::vector<double> other = {0, 170};
  EXPECT_THROW(Relocate({a, opposite, c.geometry}, {b, other, c.geometry}, e), ToolInputError);
  const ToolDescription cutter =
      LoadTool(mlp::test::SourceDir() + "/samples/tools/endmill_d10_z4_new.json");
  EXPECT_THROW(Relocate({a, opposite, c.geometry}, {b, opposite, c.geometry}, cutter),
               ToolInputError);
}

}  // namespace
}  // namespace mlp::toolcam
