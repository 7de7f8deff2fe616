#pragma once
/// @file One frame's stripe candidates held to what any opaque surface allows, whatever rendered
/// or reflected the light (issue 50).
///
/// The light plane of one frame contains the projector's centre, so it meets each epipolar plane
/// (the planes through both centres) in one line through that centre; a camera ray in that
/// epipolar plane meets the first surface once. On one epipolar line of the image, in one frame,
/// at most one candidate is direct light (seed 004 rectifies camera and projector: the epipolar
/// lines are the sensor rows of a probe whose baseline runs along x). Two candidates on one
/// epipolar line are a conflict; the candidates are first linked along the stripe into traces
/// (a reflection is a whole stripe of its own), and of two traces in conflict the one with
/// clearly more light over the lines they share is the direct one: a reflection loses light at
/// the surface that reflects it. Where the light does not tell them apart, neither is kept on the
/// lines they share: a missing point is safe, a wrong one is not. A stripe rejected for its shape
/// (saturated, double-peaked, too wide or narrow) is evidence: it takes part in the conflicts with
/// its light and is never a point, so a reflection beside it does not take its place.
///
/// Speckle: the centre of one scan line carries the speckle of the few grains across the stripe
/// there (Dorsch, Haeusler & Herrmann, Appl. Opt. 33, 1994). Along a trace, each centre is
/// replaced by a straight line fitted to the trace's centres within +-`smooth_half_lines` lines
/// (a local linear fit keeps a sloping or gently curving stripe's centre unbiased, where a plain
/// mean would not); a trace breaks where the stripe jumps (an edge, a step), so no fit spans one.

#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/stripe.h"

#include <cstdint>
#include <vector>

namespace mlp::probe_fw {

struct EpipolarOptions {
  /// Two candidates lie on one epipolar line when their lines are closer than this [px]: half
  /// a row, so that the next row (a pixel on, 0.98 px where the lens compresses) is another line.
  double same_line_px = 0.5;
  /// Candidates on neighbouring scan lines link into one trace when the second lies within this
  /// of where the trace's slope puts it [px]; a trace bridges up to `max_line_gap` lines.
  double link_gate_px = 3.0;
  int max_line_gap = 2;
  /// A conflict over at least this many lines is judged by a paired test of the two traces'
  /// light, line by line; fewer, by each trace's light on and within `few_lines_reach` of its
  /// shared lines (an unpaired test, each side at least `min_paired_lines` members), or, where a
  /// trace has fewer there, by the plain ratio `few_lines_dominance`.
  int min_paired_lines = 5;
  int few_lines_reach = 8;
  /// The stronger trace's light must be at least this many times the weaker's (mean of the
  /// per-line log ratio) and `significance` standard errors clear of equal.
  double min_dominance = 1.1;
  double significance = 4.0;
  /// Neighbouring lines share speckle grains: the paired lines count as this many times fewer.
  double lines_per_independent = 3.0;
  double few_lines_dominance = 2.0;
  /// The local line fit along a trace spans +-this many lines; 0 keeps the raw centres.
  int smooth_half_lines = 4;
  /// A trace (points and rejected candidates) on fewer lines than this is no stripe to measure.
  int min_trace_lines = 5;
};

struct EpipolarCounts {
  /// Candidates dropped because a clearly brighter trace shares their epipolar lines.
  std::uint64_t second_on_line = 0;
  /// Candidates dropped because another on their epipolar line was as bright (neither kept).
  std::uint64_t undecided = 0;
  /// Candidates dropped beside a rejected stripe on their epipolar line that outshone them.
  std::uint64_t beside_rejected = 0;
  /// Candidates on a trace of fewer than `min_trace_lines` lines.
  std::uint64_t isolated = 0;
  /// Centres moved by the fit along their trace (not a loss).
  std::uint64_t smoothed = 0;
};

/// Laser speckle along the stripe as one frame's centres show it: the contrast of the stripe's
/// light along each trace (about a parabola fitted over +-16 lines, so the light's own fall-off
/// over a curved face is no contrast; each residual clipped at 3 robust sigma, so a glint a few
/// lines long is none either) and the grain, the lag [lines]
/// at which that contrast's autocorrelation falls to one half (Goodman, "Speckle Phenomena in
/// Optics", 2007: the autocorrelation's width is the grain's size). Pixel noise alone gives a
/// contrast of a percent and no grain.
struct SpeckleEstimate {
  double contrast = 0.0;
  double grain_lines = 0.0;
  std::size_t samples = 0;  ///< centres that took part
};
SpeckleEstimate EstimateSpeckle(const std::vector<StripePoint>& points,
                                const EpipolarOptions& options);

/// The smoothing along the stripe that the estimate calls for [px, sigma]: none under
/// `kMinSpeckleContrast` or with too few samples, else twice the grain (bounded to 1..4 px).
constexpr double kMinSpeckleContrast = 0.05;
double AlongStripeSigmaPx(const SpeckleEstimate& speckle);
/// The line fit's half-window along a trace: `plain` without speckle; under speckle wide enough
/// to span 16 grains (bounded to 12 lines): the centre's speckle error averages over grains, not
/// lines, so the window follows the grain.
int SmoothHalfLines(const SpeckleEstimate& speckle, int plain);

/// The points of one frame (`points`, one scan's or both) with `rejected` (the candidates the
/// extractor rejected for their shape, never points) held to one direct candidate per epipolar
/// line, and their centres fitted along their traces. Removes the points that lose; returns
/// nothing, counts in *counts.
void KeepOneDirectPerEpipolarLine(const ProbeModel& model,
                                  const std::vector<StripePoint>& rejected,
                                  const EpipolarOptions& options,
                                  std::vector<StripePoint>* points,
                                  EpipolarCounts* counts);

}  // namespace mlp::probe_fw
