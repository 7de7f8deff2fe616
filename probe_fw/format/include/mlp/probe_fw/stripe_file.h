#pragma once
/// @file Stripe observation files (`mlprobe-stripes/1`): the stripe centres the firmware found in
/// a capture's laser frames, *not* triangulated: (sensor pixel, projector column lit). This is
/// what the probe delivers in calibration mode, before it has a projector model to triangulate
/// with; the camera/projector calibration reads it. Written by `mlp-fw stripes`.
///
/// {"format": "mlprobe-stripes/1", "probe_serial": ..., "capture_id": ...,
///  "points": [[x_px, y_px, column, quality], ...]}    x_px: sub-pixel sensor column (distorted
///                                                     image), y_px: sensor row, quality 0..1

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::probe_fw {

class StripeFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StripeObservationRecord {
  double x_px = 0.0;
  int y_px = 0;
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
