#pragma once
/// @file An EDM electrode put back after re-clamping, found again in six degrees of freedom
/// from its own surface texture in reflected light (seed 000 example 6, Fig. 4a-c).
///
/// Before the electrode is taken out, the camera, lit from its own side, records the texture of
/// its side faces (the EDM'd or ground surface's own pattern) with the electrode turned in
/// steps by the C axis: those images are the reference pattern model. After it is clamped
/// again, the same steps are recorded. Each image is cut into patches and each patch's shift
/// against the reference is found by phase correlation (OpenCV's `phaseCorrelate`: the seed
/// points to image-shift detection for this). A rigid motion of the electrode in the chuck
/// (rotation R, translation t, six numbers) moves a surface point W seen at turn C to
/// Rz(C) (R Rz(-C) W + t): the image shows that motion's y and z. Faces seen square at
/// different turns see different components (t's x shows at 90 deg), so all patches of all
/// steps give the six numbers by least squares (Gauss-Newton on the exact rotation, patches
/// far off the fit left out). Unlike example 5, where each corner moves on its own, the model
/// moves as a whole.
///
/// Frames: the chuck's (the tool frame at turn 0): z up the spindle axis, the origin on the
/// axis at the electrode's nominal end; the camera looks along +x of the turned chuck frame,
/// telecentric, its pixels mapped as the shadow camera's (ToolCameraModel: y across, h up).
///
/// The virtual reflected-light camera here draws a textured rectangular electrode (value noise
/// on a 20 um grid, fixed by a seed per face) at any pose, so the motion is known.

#include "mlp/geometry/types.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"

#include <cstdint>
#include <random>
#include <vector>

namespace mlp::toolcam {

/// A rigid motion of the electrode in the chuck frame: P' = R(rotation) P + translation.
struct ClampPose {
  geometry::Vec3 rotation_rad{0, 0, 0};  ///< rotation vector (axis times angle)
  geometry::Vec3 translation_mm{0, 0, 0};
};

/// The reflected-light camera: the shadow camera's geometry, its grey levels for the surface.
struct TextureCamera {
  ToolCameraModel geometry;  ///< size, scale, axis column, the row of h = 0; no lens distortion
  double dark = 20, bright = 220;  ///< grey of no reflection and of the brightest texture
  double noise_sigma = 2.0;        ///< grey levels, Gaussian
  unsigned texture_seed = 1;       ///< the electrode's own surface
  double texture_cell_mm = 0.02;   ///< the texture's grain
};

/// One image of `electrode` (a rectangular section) at `pose` in the chuck, the C axis turned
/// `turn_rad`: each pixel the mean of 2 x 2 rays' albedo where they meet the prism first.
std::vector<std::uint8_t> RenderTextureFrame(const ToolDescription& electrode,
                                             const ClampPose& pose,
                                             double turn_rad,
                                             const TextureCamera& camera,
                                             std::mt19937& rng);

/// Images at the C axis' steps: `frames[i]` at `turn_deg[i]`, through one camera.
struct TextureSeries {
  const std::vector<std::vector<std::uint8_t>>& frames;
  const std::vector<double>& turn_deg;
  const ToolCameraModel& camera;
};

struct RelocateOptions {
  int patch_px = 128;           ///< a patch's side (a power of two suits the FFT)
  double min_response = 0.2;    ///< phase correlation's peak below this: no texture there
  double outlier_factor = 4.0;  ///< off the fit by more than this times the median: left out
};

struct Relocation {
  ClampPose change;                    ///< the electrode now against the reference
  double rotation_deg[3] = {0, 0, 0};  ///< change.rotation_rad in degrees, about x, y, z
  /// What a four-axis machine can correct: the electrode's end point on the axis moved by the
  /// translation (X, Y, Z), and its turn about the spindle (C); the tilt (about x and y
  /// together) it cannot.
  double tilt_deg = 0.0;
  double rms_um = 0.0;  ///< the patches' shifts about the fitted motion
  int patches = 0, left_out = 0;
};

/// The change between `reference` (recorded before the electrode was taken out) and `after`
/// (the same turns, after re-clamping). Throws ToolInputError when the series do not pair (turns
/// differ, sizes differ) or the description is not an electrode, ToolError when fewer than two
/// turns 60 deg or more apart show texture (the motion along the view is then unseen) or the
/// fit does not hold.
Relocation Relocate(const TextureSeries& reference,
                    const TextureSeries& after,
                    const ToolDescription& electrode,
                    const RelocateOptions& options = {});

}  // namespace mlp::toolcam
