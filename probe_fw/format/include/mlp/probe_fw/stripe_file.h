#pragma once
/// @file Stripe observation files (`mlprobe-stripes/2`): the stripe centres the firmware found in
/// a capture's laser frames, *not* triangulated: (sensor pixel, projector column lit). This is
/// what the probe delivers in calibration mode, before it has a projector model to triangulate
/// with; the camera/projector calibration reads it. Written by `mlp-fw stripes`.
///
/// {"format": "mlprobe-stripes/2", "probe_serial": ..., "capture_id": ...,
///  "points": [[x_px, y_px, column, quality], ...]}    the stripe centre in sensor coordinates
///                                                     (distorted image), quality 0..1
/// A centre is sub-pixel across the stripe and on a whole scan line along it (a row where the
/// stripe runs down the image, a column where it runs along the rows). Version 1 files (rows
/// only: y_px a whole row) read unchanged.

#include "mlp/base/input_error.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::probe_fw {

class StripeFileError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct StripeObservationRecord {
  double x_px = 0.0, y_px = 0.0;
  double column = 0.0;
  double quality = 0.0;
};

struct StripeFile {
  std::string probe_serial, capture_id;
  std::vector<StripeObservationRecord> points;
};

/// Atomic (temp file + rename); throws StripeFileError when it cannot write.
void SaveStripeFile(const StripeFile& file, const std::string& path);
/// Throws StripeFileError naming the entry that is not a finite, in-range observation.
StripeFile LoadStripeFile(const std::string& path);

}  // namespace mlp::probe_fw
