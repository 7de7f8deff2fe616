#pragma once
/// @file Sub-pixel centres of the laser stripe in a frame, inside the ROI mask only, found across
/// the stripe whatever its direction: along the rows for a stripe that runs down the image, along
/// the columns for one that runs along the rows (a wall seen edge-on, a probe mounted turned by
/// 90 degrees, a fixed line laser across the image).
///
/// Method (Fisher & Naidu, "A comparison of algorithms for subpixel peak detection", 1996: the
/// centre of mass and Gaussian fits are the most accurate for stripes 3-6 px wide): on each scan
/// line, every run of pixels above a threshold is a candidate; its centre is the centre of mass of
/// the background-subtracted intensities in a window of +-3 sigma around the peak, re-centred once
/// (removes the window's truncation bias). Candidates that are saturated, double-peaked
/// (a reflection beside the stripe), wider than the sheet allows or cut by the ROI's edge are
/// rejected and counted. The centre of mass along a scan line lies on a straight stripe's centre
/// line at any angle; the scan closer to square across the stripe is the better conditioned, so
/// where both find a crossing, the stripe's direction decides which keeps it: of its light in a
/// 13 x 13 px window summed onto the row direction and onto the column direction, the more peaked
/// profile is the one across the stripe (summing along the stripe averages speckle away). The
/// column scan reads only the columns where the row scan saw a reason for it: a run longer than
/// a stripe is wide, a centre left to the columns, or a line lifted as a whole above the darkest
/// line (a stripe lying along it): a stripe running down the image costs it nothing.

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

/// Which scan found a centre: along a sensor row (the stripe runs down the image) or along a
/// sensor column (the stripe runs along the rows).
enum class ScanAxis : std::uint8_t { kRow, kColumn };

/// Which scans to run. Both by default; one alone reads half the pixels, for a probe whose stripe
/// runs one way over its whole measuring range.
enum class StripeAxes : std::uint8_t { kRows, kColumns, kBoth };

struct StripeOptions {
  double min_amplitude_dn = 20.0;  ///< peak above background needed for a candidate
  int window_half_px = 4;          ///< centroid window half-width (~3 sigma of a 3-5 px stripe)
  int max_width_px = 12;           ///< wider runs above half maximum are not a laser stripe
  double double_peak_ratio = 0.3;  ///< a second peak above this fraction of the first rejects
  /// ... when it lies at least this far from the first [px]. Under measured speckle
  /// (ReconstructSweep) the profile's own grains make humps inside the centroid window, so only
  /// a peak beyond the window is a second stripe there.
  int double_peak_min_px = 3;
  /// A profile narrower than this (second moment [px^2]) lies mostly on one pixel: its centre of
  /// mass locks to the pixel (biased by up to a third of a pixel) and is not a point. A design
  /// stripe has ~1.1 px^2; a face seen so that the sheet sweeps it fast narrows it.
  double min_variance_px2 = 0.2;
  StripeAxes axes = StripeAxes::kBoth;
  /// With both scans, the one along the epipolar lines (rows for a probe whose baseline runs
  /// along x) owns a crossing unless the other scan crosses the stripe this many times more
  /// squarely (its profile's peakedness; about the tangent of the stripe's angle to the
  /// epipolar scan's normal). The epipolar scan measures what triangulation needs, the
  /// stripe's place along the epipolar line; the other scan measures it across, and turns its
  /// error into depth through the surface's slope in the light plane: on a sphere's curving
  /// stripe ends, 18-42 um RMS against 2-4 um from the row scan on the same stripes (issue 50,
  /// corpus 7878 scenes 59, 64). 1: whichever crosses more squarely.
  ScanAxis epipolar_axis = ScanAxis::kRow;
  double cross_scan_dominance = 1.0;
  /// Gaussian smoothing of the frame before the scans [px, sigma]; 0: none. Laser speckle on a
  /// rough surface breaks a wide stripe's profile into grains that the double-peak test reads
  /// as a second stripe; a kernel about the grain's size averages them (Dorsch, Haeusler &
  /// Herrmann, "Laser triangulation: fundamental uncertainty in distance measurement", Appl.
  /// Opt. 33, 1994: speckle, not pixel noise, bounds the centre's precision; smoothing along
  /// the stripe trades lateral resolution for it). A symmetric kernel leaves a straight
  /// stripe's centre where it was. Pixels at full scale stay at full scale (still saturated).
  double speckle_sigma_px = 0.0;
  /// Gaussian smoothing along the stripe only [px, sigma]; 0: none. The row scan reads the frame
  /// smoothed down the columns, the column scan along the rows: speckle grains along the stripe
  /// average out while the profile across it keeps its width, and a pixel is saturated only
  /// where the stripe is at full scale along the kernel, not where one grain clipped.
  /// ReconstructSweep sets it from the frames (EstimateSpeckle, epipolar.h).
  double along_stripe_sigma_px = 0.0;
};

struct StripePoint {
  /// Sensor coordinates (AOI offset added), distorted image: sub-pixel across the stripe, the
  /// scan line's index along it (x_px for a column scan, y_px for a row scan is a whole number).
  double x_px = 0.0, y_px = 0.0;
  ScanAxis axis = ScanAxis::kRow;
  double amplitude_dn = 0.0;
  double quality = 0.0;  ///< 0..1: amplitude relative to half of full scale
  /// The profile in the centroid window above its background: its light (sum, DN) and its
  /// second moment about the centre [px^2] (reflectance.h uses both).
  double mass_dn = 0.0;
  double variance_px2 = 0.0;
  /// Under smoothing along the stripe: the light-weighted mean offset of the lines the smoothed
  /// centre averaged [lines] (along_blur.h); 0 without.
  double blur_m1_lines = 0.0;
  /// Its brightest pixel at the sensor's full scale: its light is known only from below.
  bool full_scale = false;
  /// Rejected evidence whose window the ROI's edge cuts: its light is known from below and its
  /// centre not at all (the peak may lie past the edge), so it is evidence on its epipolar line
  /// only, never a stretch of the sweep (ghost.h).
  bool cut = false;

  /// The sensor row (row scan) or column (column scan) the centre was found on.
  int Line() const { return static_cast<int>(axis == ScanAxis::kRow ? y_px : x_px); }
  /// The sub-pixel coordinate along that line.
  double Along() const { return axis == ScanAxis::kRow ? x_px : y_px; }
};

struct StripeCounts {
  /// lines: scan lines (row and column spans) read.
  std::uint64_t lines = 0, points = 0, weak = 0, saturated = 0, double_peak = 0, too_wide = 0;
  std::uint64_t cut = 0;         ///< window not inside the ROI: cut by its edge
  std::uint64_t too_narrow = 0;  ///< profile on about one pixel (StripeOptions::min_variance_px2)
  /// Found by both scans and left to the one more nearly across the stripe: not a loss.
  std::uint64_t other_axis = 0;
  /// Light that left the light plane (a reflection), told by the sweep (ghost.h): not points.
  std::uint64_t indirect = 0;
  /// The face's reflectance changes too fast across the stripe to correct (reflectance.h).
  std::uint64_t reflectance_dropped = 0;
  /// One frame's epipolar line holds at most one direct candidate (epipolar.h): dropped as the
  /// clearly weaker trace, as one of two that the light could not tell apart, or beside a
  /// stripe rejected for its shape (saturated, double-peaked...) that outshone it.
  std::uint64_t second_on_line = 0, undecided_on_line = 0, beside_rejected = 0;
  /// On a trace of a few lines only (epipolar.h): nothing along the stripe holds it.
  std::uint64_t isolated = 0;
};

/// The mask of the transposed AOI (rows become columns): what the column scan reads.
RowMask Transposed(const RowMask& mask);

/// The stripe centres of every frame of a sweep within one mask: holds the column scan's mask and
/// the transposition buffer, made once for the sweep (the board's memory is not churned per frame).
class StripeExtractor {
 public:
  /// Throws std::invalid_argument when the mask does not have one entry per row of its AOI.
  StripeExtractor(const RowMask& mask, const StripeOptions& options);
  /// Appends the centres found in `frame` to `out`: the row scan's first, then the column
  /// scan's. Candidates rejected for their shape (saturated, double-peaked, too wide, too
  /// narrow) or cut by the ROI's edge (at least min_amplitude_dn showing): counted, never
  /// points, go to `rejected` when given: they are light on their epipolar line, evidence
  /// against a weaker candidate there (epipolar.h). Throws
  /// std::invalid_argument when the frame's AOI is not the mask's.
  void Extract(const Frame& frame,
               std::vector<StripePoint>* out,
               StripeCounts* counts,
               std::vector<StripePoint>* rejected = nullptr);

 private:
  RowMask mask_, column_mask_;
  StripeOptions options_;
  std::vector<std::uint16_t> transposed_;
  std::vector<std::uint16_t> smoothed_;                    ///< the frame after speckle smoothing
  std::vector<std::uint16_t> along_rows_, along_columns_;  ///< smoothed along the stripe
  std::vector<std::uint8_t> wanted_;  ///< per AOI column: the column scan reads it
  std::vector<double> along_kernel_;  ///< the Gaussian along the stripe, -3 sigma..3 sigma
};

/// One frame: StripeExtractor(mask, options).Extract(frame, out, counts).
void ExtractStripe(const Frame& frame,
                   const RowMask& mask,
                   const StripeOptions& options,
                   std::vector<StripePoint>* out,
                   StripeCounts* counts);

}  // namespace mlp::probe_fw
