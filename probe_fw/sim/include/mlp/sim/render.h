#pragma once
/// @file The virtual probe: renders the frames a real probe would take of a scene, from the same
/// probe model the firmware uses, and knows the truth behind every pixel.
///
/// Physics per pixel (docs/PROBE.md, "Virtual probe"): the camera ray through the distorted pixel
/// centre meets the workpiece (occlusion from the camera); the surface point is lit by the laser
/// unless the workpiece blocks the projector (shadowing), with Lambertian irradiance cos(incidence)
/// x reflectance; the laser sheet is Gaussian in projector columns and integrated over the pixel
/// width along the row; multiplicative speckle; shop light; shot noise (Gaussian approximation of
/// Poisson) and read noise in electrons; gain to full scale at the full well; quantisation and
/// saturation at the camera's bit depth. Deterministic for a given seed, frame by frame.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/sim/as_built.h"
#include "mlp/sim/scene.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace mlp::sim {

class SpeckleImager;

struct SweepOptions {
  probe_fw::Aoi aoi;          ///< the window read out
  double first_column = 0.0;  ///< projector column of the first laser frame
  double last_column = 0.0;   ///< inclusive
  double column_step = 1.0;   ///< > 0
  std::uint64_t seed = 1;
  bool noise = true;  ///< false: noiseless frames (no speckle, shot or read noise)
  /// LED frame: pixels on a reflectance or depth edge are averaged over n x n sub-pixel rays
  /// (a real pixel integrates its whole area; a calibration target's corners need it).
  int led_supersampling = 1;
  /// false: the LED frame only (a camera calibration view); no laser frames are rendered.
  bool laser_frames = true;
  /// One specular inter-reflection (scenes with a glossy face only; interreflection.cc).
  bool interreflections = true;
  /// Exposure time relative to the one the model's photometry (noise.*_e) is given for: scales
  /// every light (laser, LED ring, shop light) before the noise. Dark metal needs more.
  double exposure = 1.0;
};

/// Sheet light that reaches the camera after one specular reflection off another face: where the
/// camera sees the point it lands on (AOI pixel coordinates, continuous), the actual projector
/// column whose sheet centre sends it, and the electrons it gives while that column is lit.
struct GhostSplat {
  float x = 0.0f, y = 0.0f;
  float column = 0.0f;
  float electrons = 0.0f;
};

/// Adds the splats of the columns within 3 sheet half-widths of `actual_column` to an image of
/// width x height pixels sampled `oversampling` times per pixel and axis (row-major), each
/// weighted by the sheet's Gaussian and shared bilinearly; a sub-sample receives q^2 times a
/// pixel's electrons, so the pixel's mean over its sub-samples is the pixel's light.
void SplatGhosts(const std::vector<GhostSplat>& splats,
                 double actual_column,
                 double sheet_halfwidth_cols,
                 int width,
                 int height,
                 int oversampling,
                 float* image);

/// What lies behind one pixel centre.
struct PixelTruth {
  bool hit = false;  ///< the camera ray meets the workpiece
  bool lit = false;  ///< ... and the projector sees that point
  Vec3 point_in_probe = Vec3::Zero();
  double projector_column = 0.0;  ///< the commanded column whose sheet centre lights the point
};

struct RenderedCapture {
  probe_fw::Frame led;
  std::vector<probe_fw::Frame> laser;
  std::vector<PixelTruth> truth;   ///< AOI pixels, row-major
  std::vector<GhostSplat> ghosts;  ///< the inter-reflected light, sorted by column
};

class VirtualProbe {
 public:
  VirtualProbe(probe_fw::ProbeModel model, Scene scene);
  /// Renders with the probe as built (as_built.h): the firmware is given another model.
  VirtualProbe(AsBuiltProbe as_built, Scene scene);

  /// The model the frames are rendered with (the as-built one's camera and projector).
  const probe_fw::ProbeModel& model() const { return model_; }
  const AsBuiltOptics& optics() const { return optics_; }
  const Scene& scene() const { return scene_; }
  Pose3 McsFromProbe(const Capture& capture) const {
    return capture.mcs_from_flange * scene_.flange_from_probe;
  }

  /// The LED frame and one laser frame per projector column of the sweep. Throws
  /// probe_fw::RequestError for a sweep the sensor or the projector cannot make.
  RenderedCapture Render(const Capture& capture, const SweepOptions& options) const;

  /// Projector columns (commanded) whose light can reach the AOI: those of the surface under a
  /// grid x grid lattice of its pixels (3: corners, edge midpoints and centre), widened by 3
  /// columns. A finer grid finds a small workpiece (a calibration board) in a large AOI. Throws
  /// SceneError when none is seen.
  void ColumnsReaching(const Capture& capture,
                       const probe_fw::Aoi& aoi,
                       double* first,
                       double* last,
                       int grid = 3) const;

  /// Surface point (probe frame) seen through a continuous distorted pixel position, if any.
  std::optional<Vec3> SurfaceAt(const Capture& capture, const geometry::Vec2& pixel) const;
  /// True centre of the stripe of projector column `column` on sensor row `row`, between sensor
  /// columns x_begin and x_end: where the sheet's centre plane crosses the row (bisection to
  /// 1e-6 px on exact ray casts). Empty when the stripe is not on that stretch of row, or is
  /// shadowed there.
  std::optional<double> TrueStripeCentre(
      const Capture& capture, double column, int row, int x_begin, int x_end) const;

 private:
  struct Pixel;
  struct Sheet;
  struct Frames;  ///< render.cc: a capture's frames from per-pixel signals
  struct Ghosts;  ///< interreflection.cc: the stripe reflected from face to face
  std::vector<GhostSplat> Interreflections(const Pose3& mcs_from_probe,
                                           const SweepOptions& o,
                                           const std::vector<Pixel>& pixels) const;
  /// Whether the camera sees a point (not hidden by another surface), and at which pixel of the
  /// AOI (sensor coordinates).
  bool SeenAt(const Pose3& mcs_from_probe,
              const probe_fw::Aoi& aoi,
              const Vec3& point_mcs,
              geometry::Vec2* pixel) const;
  std::vector<Sheet> SheetAcrossPixels(const std::vector<Pixel>& pixels, int w, int h) const;
  void SpeckledSheet(const std::vector<Pixel>& pixels,
                     const std::vector<Sheet>& sheets,
                     int w,
                     int h,
                     double actual_column,
                     SpeckleImager* imager,
                     std::vector<double>* laser_e) const;
  std::vector<double> LedResponse(const Pose3& pose,
                                  const SweepOptions& o,
                                  const std::vector<Pixel>& pixels) const;
  /// `laser` false: what the LED frame needs only (no projector column, no shadow ray).
  Pixel Trace(const Pose3& mcs_from_probe, const geometry::Vec2& pixel, bool laser = true) const;

  probe_fw::ProbeModel model_;
  AsBuiltOptics optics_;
  Scene scene_;
};

}  // namespace mlp::sim
