#pragma once
/// @file The probe as built, for the virtual probe only (issue 16, part 1): a real probe differs
/// from its design and is known to the product only through its calibration. The as-built file
/// (`mlprobe-as-built/1`, docs/PROBE.md, "The probe as built") holds the probe model the probe
/// really has (camera and projector numbers off the design, the mirror's non-linearity and the
/// sheet's smile: probe_model.h) and what no probe model describes: a window in front of the
/// camera (a plane-parallel plate) that shifts every ray sideways. The firmware and the host never
/// read this file; the renderer renders with it.

#include "mlp/base/input_error.h"
#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/probe_model.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::sim {

using geometry::Pose3;
using geometry::Vec3;

class AsBuiltError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct AsBuiltOptics {
  /// A plane-parallel plate in front of the camera: thickness [mm] (0: none), refractive index,
  /// unit normal in the probe frame (z forward).
  double window_thickness_mm = 0.0;
  double window_index = 1.5;
  Vec3 window_normal_in_probe = Vec3::UnitZ();

  /// Throws AsBuiltError naming the first field out of range.
  void Validate() const;
  /// Where a camera ray leaving the pinhole along the unit direction `d` (probe frame) emerges
  /// from the window: the emerging ray is parallel to d, its origin moved by this [mm]. A
  /// plane-parallel plate moves every ray of one direction by the same vector wherever it sits.
  Vec3 WindowShift(const Vec3& d) const;
};

struct AsBuiltProbe {
  probe_fw::ProbeModel model;  ///< the camera and projector the probe really has
  AsBuiltOptics optics;
  bool plain_model = false;  ///< read from a plain probe model file: nothing but the model
};

/// Points over the working volume (planes z = 105, 120, 135 mm): each true point where the real
/// camera ray of a pixel (through the window) meets the plane, lit by the commanded column whose
/// (curved) sheet reaches it through the (non-linear) mirror, and the same pixel and column
/// triangulated with `model`. Pixels every 150 px over the image (100 px from its edges), or
/// every 20 px over `aoi`.
void WorkingVolumePoints(const AsBuiltProbe& truth,
                         const probe_fw::ProbeModel& model,
                         const probe_fw::Aoi* aoi,
                         std::vector<Vec3>* triangulated,
                         std::vector<Vec3>* true_points);

/// Where a model's probe frame lies in the true camera frame: the rigid transform (Umeyama, no
/// scale) that best takes points triangulated with `model` onto the true surface points over the
/// working volume (planes z = 105, 120, 135 mm, through the window), over the whole image (pixels
/// every 150 px) or, given `aoi`, over that window (every 20 px): a calibrated model is rigidly
/// like the truth only to its calibration's error, so the frame a measurement in one window
/// sees is best found there.
/// Calibration fixes its probe frame by its own camera estimate (a window moves the pinhole
/// T (1 - 1/n) along the axis, 0.68 mm for the sample's 2 mm of BK7; a principal point 0.5 px
/// off turns it by 1e-4 rad), and the hand-eye measures M in that frame: the true M of a
/// calibrated chain is the scene's flange_from_probe times this. `rms_mm`: what is left after
/// the alignment.
Pose3 TrueFromModelFrame(const AsBuiltProbe& truth,
                         const probe_fw::ProbeModel& model,
                         const probe_fw::Aoi* aoi = nullptr,
                         double* rms_mm = nullptr);

/// Reads `mlprobe-as-built/1`, or a plain probe model file (`mlprobe-probe-model/1`: the probe
/// exactly as modelled, nominal optics). Throws AsBuiltError (or ProbeModelError for the model).
AsBuiltProbe ParseAsBuilt(const std::string& json_text);
AsBuiltProbe LoadAsBuilt(const std::string& path);

}  // namespace mlp::sim
