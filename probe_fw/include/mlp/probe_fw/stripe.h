#pragma once
/// @file Sub-pixel centres of the laser stripe in a frame, row by row, inside the ROI mask only.
///
/// Method (Fisher & Naidu, "A comparison of algorithms for subpixel peak detection", 1996: the
/// centre of mass and Gaussian fits are the most accurate for stripes 3-6 px wide): on each row,
/// every run of pixels above a threshold is a candidate; its centre is the centre of mass of the
/// background-subtracted intensities in a window of +-3 sigma around the peak, re-centred once
/// (removes the window's truncation bias). Candidates that are saturated, double-peaked
/// (a reflection beside the stripe), wider than the sheet allows or cut by the ROI's edge are
/// rejected and counted.

#include "mlp/probe_fw/frame.h"

#include <cstdint>
#include <utility>
#include <vector>

namespace mlp::probe_fw {

/// The pixels to process: per AOI row, half-open column intervals [begin, end) in AOI coordinates.
struct RowMask {
  Aoi aoi;
  std::vector<std::vector<std::pair<int, int>>> rows;
  /// Every pixel of the AOI.
  static RowMask Full(const Aoi& aoi);
  std::size_t PixelCount() const;
};

struct StripeOptions {
  double min_amplitude_dn = 20.0;  ///< peak above background needed for a candidate
  int window_half_px = 4;          ///< centroid window half-width (~3 sigma of a 3-5 px stripe)
  int max_width_px = 12;           ///< wider runs above half maximum are not a laser stripe
  double double_peak_ratio = 0.3;  ///< a second peak above this fraction of the first rejects
};

struct StripePoint {
  double x_px = 0.0;  ///< sensor column (AOI offset added), distorted image
  int y_px = 0;       ///< sensor row
  double amplitude_dn = 0.0;
  double quality = 0.0;  ///< 0..1: amplitude relative to full scale, lowered by asymmetry
};

struct StripeCounts {
  std::uint64_t rows = 0, points = 0, weak = 0, saturated = 0, double_peak = 0, too_wide = 0;
  std::uint64_t cut = 0;  ///< window not inside the ROI: cut by its edge
  /// Light that left the light plane (a reflection), told by the sweep (ghost.h): not points.
  std::uint64_t indirect = 0;
};

/// Appends the stripe centres found in `frame` within `mask` to `out`.
void ExtractStripe(const Frame& frame,
                   const RowMask& mask,
                   const StripeOptions& options,
                   std::vector<StripePoint>* out,
                   StripeCounts* counts);

}  // namespace mlp::probe_fw
