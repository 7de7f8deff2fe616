#pragma once
/// @file From stripe centres to points: the camera ray through the (undistorted) stripe centre
/// meets the light plane of the projector column lit in that frame (the projector as an inverse
/// camera: DIGEST 004 section 3).

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/stripe.h"

#include <optional>
#include <vector>

namespace mlp::probe_fw {

struct CloudPoint {
  Vec3 point_in_probe = Vec3::Zero();  ///< [mm]
  double quality = 0.0;                ///< 0..1, from the stripe
  double x_px = 0.0, y_px = 0.0;       ///< where it was seen (distorted sensor coordinates)
  ScanAxis axis = ScanAxis::kRow;      ///< which scan found it (stripe.h)
  double column = 0.0;                 ///< projector column of its frame
};

/// The point where the ray through sensor pixel (x_px, y_px) meets the light plane of `column`.
/// Empty when the ray grazes the plane (a triangulation angle under 0.06 deg has no depth
/// resolution): an expected outcome for a pixel, not an error (docs/DEVELOPING.md, Errors).
std::optional<Vec3> Triangulate(const ProbeModel& model, double x_px, double y_px, double column);

/// Stripe extraction and triangulation over every laser frame of a sweep.
std::vector<CloudPoint> ReconstructSweep(const ProbeModel& model,
                                         const std::vector<Frame>& laser_frames,
                                         const RowMask& mask,
                                         const StripeOptions& options,
                                         StripeCounts* counts);

}  // namespace mlp::probe_fw
