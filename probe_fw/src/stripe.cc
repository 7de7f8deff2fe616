#include "mlp/probe_fw/stripe.h"

#include "mlp/base/check.h"
#include "mlp/base/raster.h"
#include "mlp/probe_fw/along_blur.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::probe_fw {
namespace {

// The pixels in scan coordinates: `lines` lines of `length` pixels each, u along a line, v the
// line: the frame's rows, or the rows of its transpose when scanning the columns.
struct Raster {
  const std::uint16_t* pixels;
  int length, lines;
  const std::uint16_t* Line(int v) const {
    return pixels + static_cast<std::size_t>(v) * static_cast<std::size_t>(length);
  }
};

// One scan's context: the raster, which axis of the sensor it scans, and where the AOI sits.
struct Scan {
  Raster raster;
  ScanAxis axis;
  int u0, v0;           // sensor coordinates of the raster's (0, 0) along u and v
  bool other_axis_too;  // the other axis is scanned as well: the stripe's direction decides
  // The row scan marks here (per AOI column) where the column scan is wanted: around runs
  // longer than a stripe is wide, and around centres left to the other axis. Null: no marking.
  std::vector<std::uint8_t>* wanted = nullptr;
  std::vector<StripePoint>* rejected = nullptr;  // candidates rejected for their shape, if asked
  // Under smoothing along the stripe, for the moments along_blur.h takes its shift out with:
  // the frame before it, read untransposed (the kernel reaches past a column band's edge; AOI
  // width x height, row-major; the scan's line v is the AOI's line first_line + v), and the
  // Gaussian's weights (offsets -K..K).
  const std::uint16_t* unsmoothed = nullptr;
  int width = 0, height = 0, first_line = 0;
  const std::vector<double>* along_kernel = nullptr;

  // The unsmoothed pixel at u along AOI line `line`.
  std::uint16_t Unsmoothed(int u, int line) const {
    const std::size_t at = axis == ScanAxis::kRow ? static_cast<std::size_t>(line) * width + u
                                                  : static_cast<std::size_t>(u) * width + line;
    return unsmoothed[at];
  }
  int AoiLines() const { return axis == ScanAxis::kRow ? height : width; }
};

// Marks [begin, end) of the other scan's lines as wanted, widened so that its windows fit.
void Want(const Scan& scan, int begin, int end, int margin) {
  if (!scan.wanted) return;
  const int n = static_cast<int>(scan.wanted->size());
  for (int i = std::max(0, begin - margin); i < std::min(n, end + margin); ++i)
    (*scan.wanted)[static_cast<size_t>(i)] = 1;
}

struct Span {
  const std::uint16_t* row;  // the scan line
  int begin, end;            // [begin, end) along it
};

// Mean of the two pixels on each side just outside the centroid window: the local background.
double LocalBackground(const Span& s, int peak, int half) {
  double sum = 0.0;
  int count = 0;
  for (int d : {half + 1, half + 2}) {
    for (int x : {peak - d, peak + d}) {
      if (x >= s.begin && x < s.end) sum += s.row[x], ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

// Centre of mass of intensity above `bg` in [centre - half, centre + half]; the light and the
// second moment about the centre when asked for.
double Centroid(const Span& s,
                int centre,
                int half,
                double bg,
                double* mass_out = nullptr,
                double* variance_out = nullptr) {
  double mass = 0.0, moment = 0.0, second = 0.0;
  for (int x = std::max(s.begin, centre - half); x <= std::min(s.end - 1, centre + half); ++x) {
    const double w = std::max(0.0, s.row[x] - bg);
    const double dx = x - centre;
    mass += w, moment += w * dx, second += w * dx * dx;
  }
  if (!(mass > 0.0)) return centre;
  const double mean = moment / mass;
  if (mass_out) *mass_out = mass;
  if (variance_out) *variance_out = std::max(0.0, second / mass - mean * mean);
  return centre + mean;
}

// The two loops that read every pixel of a line, by hand with OpenCV's universal intrinsics
// (SSE2 here, NEON on the probe's ARM board): GCC 12 made the line's minimum a five-instruction
// compare-and-blend per 8 pixels on SSE2 and the background skip 16 scalar compares per block;
// the two were 60 % of the stripe step's time (perf, issue 50's speed target).
constexpr int kSkipBlock = 16;

// The darkest pixel of [begin, end).
std::uint16_t LineFloor(const std::uint16_t* row, int begin, int end) {
  std::uint16_t lowest = 0xffff;
  int x = begin;
#if CV_SIMD128
  // Four running minima: one would chain every load's minimum on the one before (rows only,
  // 0.97 -> 0.87 ms a full frame).
  constexpr std::ptrdiff_t kLanes = 8, kStep = 4 * kLanes;
  if (end - begin >= kStep) {
    const std::uint16_t* p = row + x;
    cv::v_uint16x8 m0 = cv::v_load(p), m1 = cv::v_load(p + kLanes);
    cv::v_uint16x8 m2 = cv::v_load(p + 2 * kLanes), m3 = cv::v_load(p + 3 * kLanes);
    for (x += kStep; x + kStep <= end; x += kStep) {
      p = row + x;
      m0 = cv::v_min(m0, cv::v_load(p));
      m1 = cv::v_min(m1, cv::v_load(p + kLanes));
      m2 = cv::v_min(m2, cv::v_load(p + 2 * kLanes));
      m3 = cv::v_min(m3, cv::v_load(p + 3 * kLanes));
    }
    lowest = cv::v_reduce_min(cv::v_min(cv::v_min(m0, m1), cv::v_min(m2, m3)));
  }
#endif
  for (; x < end; ++x) lowest = std::min(lowest, row[x]);
  return lowest;
}

// Whether any of the kSkipBlock pixels from p on is at or above `threshold` (<= 0xffff).
bool BlockReaches(const std::uint16_t* p, int threshold) {
#if CV_SIMD128
  const cv::v_uint16x8 brightest = cv::v_max(cv::v_load(p), cv::v_load(p + 8));
  return cv::v_check_any(brightest >= cv::v_setall_u16(static_cast<std::uint16_t>(threshold)));
#else
  return *std::max_element(p, p + kSkipBlock) >= threshold;
#endif
}

enum class Verdict { kPoint, kWeak, kSaturated, kDoublePeak, kTooWide, kCut };

Verdict Judge(const Span& s, int peak, double bg, int max_level, const StripeOptions& o) {
  // The window and its background pixels must lie inside the ROI: a stripe cut by the ROI's
  // edge has a one-sided centre of mass (biased by up to half its width).
  const int margin = o.window_half_px + 2;
  if (peak - margin < s.begin || peak + margin >= s.end) return Verdict::kCut;
  const double amplitude = s.row[peak] - bg;
  if (amplitude < o.min_amplitude_dn) return Verdict::kWeak;
  const int reach = 3 * o.window_half_px;
  int saturated = 0, above_half = 0;
  bool double_peak = false;
  for (int x = std::max(s.begin, peak - reach); x <= std::min(s.end - 1, peak + reach); ++x) {
    const double v = s.row[x] - bg;
    saturated += s.row[x] >= max_level;
    above_half += v > 0.5 * amplitude;
    // A local maximum 3 px or more from the peak, and strong: a second stripe (reflection).
    const bool local_max =
        x > s.begin && x + 1 < s.end && s.row[x] >= s.row[x - 1] && s.row[x] >= s.row[x + 1];
    double_peak = double_peak || (std::abs(x - peak) >= o.double_peak_min_px && local_max &&
                                  v > o.double_peak_ratio * amplitude);
  }
  // Saturation named first: a clipped stripe's flat top is a run of equal "local maxima" and
  // was counted a double peak, so an over-exposed image said 3 % saturated (issue 52: the
  // Blaser im20 at 3x exposure, its points 1.6 mm off). Both refuse the candidate alike.
  if (saturated >= 2) return Verdict::kSaturated;
  if (double_peak) return Verdict::kDoublePeak;
  if (above_half > o.max_width_px) return Verdict::kTooWide;
  return Verdict::kPoint;
}

// Peak over mean of a profile: about the stripe's length over its width across a stripe, near
// 1 along it. The profile's sums less `floor` each.
double Peakedness(const std::int32_t* sums, int n, std::int32_t floor) {
  std::int64_t total = 0, peak = 0;
  for (int k = 0; k < n; ++k) {
    const std::int64_t above = sums[k] - floor;
    total += above, peak = std::max(peak, above);
  }
  return total > 0 ? static_cast<double>(peak) * n / static_cast<double>(total) : 0.0;
}

constexpr int kMaxDirectionHalf = 15;

// The direction test's sums (below) for a window at most 16 pixels across, two vectors of 8 a
// line with the pixels past the window masked off: onto_u[i] the window's column sums, onto_v[j]
// its line sums, *darkest its darkest pixel. The scalar loop GCC made of it was a fifth of the
// stripe step (perf). False where it does not apply (wider, or 16 pixels would pass the line's
// end): the caller sums by hand.
bool WindowSums16(const Raster& r,
                  int i0,
                  int nu,
                  int j0,
                  int nv,
                  std::int32_t* onto_u,
                  std::int32_t* onto_v,
                  std::uint16_t* darkest) {
#if CV_SIMD128
  constexpr int kLanes = 8, kWide = 2 * kLanes;
  if (nu > kWide || i0 + kWide > r.length) return false;
  std::array<std::uint16_t, kWide> keep{};
  std::fill(keep.begin(), keep.begin() + nu, std::uint16_t{0xffff});
  const cv::v_uint16x8 keep_lo = cv::v_load(keep.data()),
                       keep_hi = cv::v_load(keep.data() + kLanes);
  cv::v_uint32x4 acc[4] = {cv::v_setzero_u32(), cv::v_setzero_u32(), cv::v_setzero_u32(),
                           cv::v_setzero_u32()};
  cv::v_uint16x8 lowest = cv::v_setall_u16(0xffff);
  for (int j = 0; j < nv; ++j) {
    const std::uint16_t* line = r.Line(j0 + j) + i0;
    const cv::v_uint16x8 lo = cv::v_load(line), hi = cv::v_load(line + kLanes);
    // Masked lanes: 0 in the sums, full scale in the minimum.
    lowest = cv::v_min(lowest, cv::v_min(lo | ~keep_lo, hi | ~keep_hi));
    cv::v_uint32x4 q[4];
    cv::v_expand(lo & keep_lo, q[0], q[1]);
    cv::v_expand(hi & keep_hi, q[2], q[3]);
    for (int k = 0; k < 4; ++k) acc[k] += q[k];
    onto_v[j] = static_cast<std::int32_t>(cv::v_reduce_sum((q[0] + q[1]) + (q[2] + q[3])));
  }
  std::array<std::uint32_t, kWide> columns{};
  for (std::ptrdiff_t k = 0; k < 4; ++k) cv::v_store(columns.data() + 4 * k, acc[k]);
  for (int i = 0; i < nu; ++i)
    onto_u[i] = static_cast<std::int32_t>(columns[static_cast<size_t>(i)]);
  *darkest = cv::v_reduce_min(lowest);
  return true;
#else
  return false;
#endif
}

// Whether the stripe through (u, v) crosses this scan's lines more squarely than the other
// scan's: its light in a square window (above the window's darkest pixel) summed onto the u axis
// is more peaked than summed onto v. A sum along the stripe averages speckle away, and a second
// stripe beside it (a reflection) keeps the profile across them peaked, where second moments
// would call two parallel stripes a blob. Ties belong to the epipolar scan, so a crossing both
// scans find has exactly one owner. One pass of integer sums: the darkest pixel comes off each sum
// afterwards (n times it), which is the same number as summing the pixels less it.
bool AcrossThisScan(const Scan& scan, double u, int v, int half_px, const StripeOptions& o) {
  const Raster& r = scan.raster;
  const int half = std::min(half_px, kMaxDirectionHalf);
  const int uc = static_cast<int>(std::lround(u));
  const int j0 = std::max(0, v - half), j1 = std::min(r.lines - 1, v + half);
  const int i0 = std::max(0, uc - half), i1 = std::min(r.length - 1, uc + half);
  if (i1 < i0 || j1 < j0) return scan.axis == ScanAxis::kRow;
  const int nu = i1 - i0 + 1, nv = j1 - j0 + 1;
  std::uint16_t darkest = 0xffff;
  // 31 pixels of 16 bits at most in a sum: 32-bit sums cannot overflow.
  std::array<std::int32_t, 2 * kMaxDirectionHalf + 1> onto_u{}, onto_v{};
  if (!WindowSums16(r, i0, nu, j0, nv, onto_u.data(), onto_v.data(), &darkest)) {
    for (int j = 0; j < nv; ++j) {
      const std::uint16_t* line = r.Line(j0 + j) + i0;
      std::int32_t sum = 0;
      for (int i = 0; i < nu; ++i) {
        darkest = std::min(darkest, line[i]);
        onto_u[static_cast<size_t>(i)] += line[i];
        sum += line[i];
      }
      onto_v[static_cast<size_t>(j)] = sum;
    }
  }
  const double across_u = Peakedness(onto_u.data(), nu, std::int32_t{darkest} * nv);
  const double across_v = Peakedness(onto_v.data(), nv, std::int32_t{darkest} * nu);
  const double k = std::max(1.0, o.cross_scan_dominance);
  if (scan.axis == o.epipolar_axis) return k * across_u >= across_v;
  return across_u > k * across_v;
}

StripePoint MakePoint(
    const Scan& scan, double u, int v, double amplitude, int peak_level, int max_level) {
  StripePoint p;
  p.axis = scan.axis;
  const double along = u + scan.u0, line = v + scan.v0;
  p.x_px = scan.axis == ScanAxis::kRow ? along : line;
  p.y_px = scan.axis == ScanAxis::kRow ? line : along;
  p.amplitude_dn = amplitude;
  p.quality = std::clamp(amplitude / (0.5 * max_level), 0.0, 1.0);
  p.full_scale = peak_level >= max_level;
  return p;
}

// The next run of pixels at or above `threshold` from *x on: [*begin, *end) and its brightest
// pixel; *x moves past it. False when the span has none left.
bool NextRun(const Span& s, int threshold, int* x, int* begin, int* end, int* peak) {
  while (*x < s.end) {
    // Most of a row is background: skip it 16 pixels at a time (a vectorised maximum).
    if (*x + kSkipBlock <= s.end && !BlockReaches(s.row + *x, threshold)) {
      *x += kSkipBlock;
      continue;
    }
    if (s.row[*x] >= threshold) break;
    ++*x;
  }
  if (*x >= s.end) return false;
  *begin = *end = *peak = *x;
  while (*end < s.end && s.row[*end] >= threshold) {
    if (s.row[*end] > s.row[*peak]) *peak = *end;
    ++*end;
  }
  *x = *end;
  return true;
}

// An over-exposed stripe's top is a plateau at full scale, and the brightest pixel NextRun
// gives is its first: the background window (5-6 px either side) then lay on the far flank, an
// over-exposed stripe's light came out below a dimmer reflection's beside it, and the epipolar
// test kept the reflection (issue 50: corpus 7272 scene 133, a copy at 0.7 standing 49 px beside
// an over-exposed stripe: light 196-202 DN against the reflection's 230-234, 1,265 points up to
// 5.8 mm off). The plateau's middle instead; a peak below full scale is left where it is.
int PlateauMiddle(const Span& s, int peak, int run_end, int max_level) {
  if (s.row[peak] < max_level) return peak;
  int last = peak;
  while (last + 1 < run_end && s.row[last + 1] >= max_level) ++last;
  return peak + (last - peak) / 2;
}

// Counts a candidate the judge rejected; true when it is a point.
bool CountVerdict(Verdict v, StripeCounts* counts) {
  switch (v) {
    case Verdict::kWeak:
      ++counts->weak;
      return false;
    case Verdict::kSaturated:
      ++counts->saturated;
      return false;
    case Verdict::kDoublePeak:
      ++counts->double_peak;
      return false;
    case Verdict::kTooWide:
      ++counts->too_wide;
      return false;
    case Verdict::kCut:
      ++counts->cut;
      return false;
    case Verdict::kPoint:
      break;
  }
  return true;
}

// The stripe's centre near `peak` [px along the line]: the window re-centred once on the first
// estimate, which removes the bias of a window off-centre by up to half a pixel. Its
// background, mass and variance in *bg, *mass, *variance.
double ReCentred(const Span& s,
                 int peak,
                 double first_bg,
                 const StripeOptions& o,
                 double* bg,
                 double* mass,
                 double* variance,
                 int* window_centre) {
  const double first = Centroid(s, peak, o.window_half_px, first_bg);
  const int centre = std::clamp(static_cast<int>(std::lround(first)),
                                s.begin + o.window_half_px + 2, s.end - o.window_half_px - 3);
  *bg = LocalBackground(s, centre, o.window_half_px);
  *mass = 0.0, *variance = 0.0;
  *window_centre = centre;
  return Centroid(s, centre, o.window_half_px, *bg, mass, variance);
}

// The scan reads `pixels` (the AOI before smoothing along the stripe) for AlongMoments.
void WithUnsmoothed(const std::uint16_t* pixels,
                    const Aoi& aoi,
                    int first_line,
                    const std::vector<double>& kernel,
                    Scan* scan) {
  scan->unsmoothed = pixels, scan->width = aoi.width, scan->height = aoi.height;
  scan->first_line = first_line, scan->along_kernel = &kernel;
}

// Whether smoothing along the stripe read only lines of the AOI for line `v`: within its reach
// of the AOI's edge it read lines inside again (OpenCV's reflected border), and the stripe's
// slope times that one-sided reach moves the centre by up to a pixel with nothing beyond the edge
// to tell by how much. Such a centre is cut, as one whose window the ROI cuts across the stripe.
bool AlongKernelInside(const Scan& scan, int v) {
  if (!scan.unsmoothed) return true;
  const int reach = static_cast<int>(scan.along_kernel->size() / 2);
  const int line = scan.first_line + v;
  return line - reach >= 0 && line + reach < scan.AoiLines();
}

// The smoothed window's light is the kernel's sum of each unsmoothed line's light in the same
// window (above the same background): the mean line offset M1, weighted so (along_blur.h). The
// kernel lies inside the AOI (AlongKernelInside).
void AlongMoments(
    const Scan& scan, const Span& s, int v, int centre, int half, double bg, StripePoint* p) {
  const std::vector<double>& kernel = *scan.along_kernel;
  const int reach = static_cast<int>(kernel.size() / 2);
  const int x0 = std::max(s.begin, centre - half), x1 = std::min(s.end - 1, centre + half);
  double light = 0.0, first = 0.0;
  for (std::size_t tap = 0; tap < kernel.size(); ++tap) {
    const int k = static_cast<int>(tap) - reach;  // the line's offset
    const int line = scan.first_line + v + k;
    double m = 0.0;
    for (int x = x0; x <= x1; ++x) m += scan.Unsmoothed(x, line) - bg;
    const double w = kernel[tap] * m;
    light += w, first += w * k;
  }
  if (light > 0.0) p->blur_m1_lines = first / light;
}

// A centre that passed the shape tests, waiting for the direction test and the rest.
struct Candidate {
  Span span;
  int v, window_centre;
  double u, amplitude, bg;
  int peak_level;
  double mass, variance;
};

// The direction test's square window reaches this many lines past the candidate's.
int DirectionReach(const StripeOptions& o) {
  return std::min(o.window_half_px + 2, kMaxDirectionHalf);
}

// Room marked around what the other scan is wanted for, so that its windows (centroid and
// direction) fit.
int WantMargin(const StripeOptions& o) { return 2 * (o.window_half_px + 2); }

// The last tests of a candidate, and its point. Run a few lines after the candidate's own
// (ScanLines): the direction test's window then lies in lines the scan has just read, in cache,
// where run at once it read DirectionReach lines ahead from memory (a quarter of the stripe step's
// time on a full frame, perf).
void Settle(const Candidate& c,
            const Scan& scan,
            int max_level,
            const StripeOptions& o,
            std::vector<StripePoint>* out,
            StripeCounts* counts) {
  if (scan.other_axis_too && !AcrossThisScan(scan, c.u, c.v, DirectionReach(o), o)) {
    ++counts->other_axis;
    const int at = static_cast<int>(std::lround(c.u));
    Want(scan, at, at + 1, WantMargin(o));
    return;
  }
  if (!AlongKernelInside(scan, c.v)) {
    ++counts->cut;
    return;
  }
  out->push_back(MakePoint(scan, c.u, c.v, c.amplitude, c.peak_level, max_level));
  out->back().mass_dn = c.mass, out->back().variance_px2 = c.variance;
  if (scan.unsmoothed)
    AlongMoments(scan, c.span, c.v, c.window_centre, o.window_half_px, c.bg, &out->back());
  ++counts->points;
}

// Finds the candidates of one span of line v into *pending (rejections counted, those rejected
// for their shape kept as evidence when asked); returns the span's darkest pixel.
std::uint16_t ScanSpan(const Span& s,
                       const Scan& scan,
                       int v,
                       int max_level,
                       const StripeOptions& o,
                       std::vector<Candidate>* pending,
                       StripeCounts* counts) {
  const std::uint16_t lowest = LineFloor(s.row, s.begin, s.end);
  const double threshold_dn = lowest + o.min_amplitude_dn;
  // Integer threshold: a pixel is a candidate when row[x] >= threshold (same test as the real).
  // Clamped below by 0 (every pixel reaches it, as before): the block skip compares in 16 bits.
  const int threshold = std::max(0, static_cast<int>(std::ceil(threshold_dn)));
  if (threshold > 0xffff) return lowest;  // no pixel can reach it
  int x = s.begin, run_begin = 0, run_end = 0, peak = 0;
  while (NextRun(s, threshold, &x, &run_begin, &run_end, &peak)) {
    peak = PlateauMiddle(s, peak, run_end, max_level);
    // A run longer than a stripe is wide may be a stripe running along the line: the column
    // scan is wanted there, with room for its windows (centroid and direction).
    if (run_end - run_begin > o.max_width_px) Want(scan, run_begin, run_end, WantMargin(o));
    const double bg = LocalBackground(s, peak, o.window_half_px);
    const Verdict verdict = Judge(s, peak, bg, max_level, o);
    // A stripe rejected for its shape is still light on this epipolar line (epipolar.h). So is
    // one the ROI's edge cuts: a sweep's first or last sheet often meets the part at the frame's
    // edge, and a reflection or copy inside then stood alone on its lines and was kept (issue 50:
    // corpus 7676 scenes 98 and 103, 102 and 572 points 2-11 mm off). Its light is known from
    // below (the part inside), enough to outshine a dimmer copy.
    const bool cut_light = verdict == Verdict::kCut && s.row[peak] - bg >= o.min_amplitude_dn;
    const bool evidence = verdict == Verdict::kSaturated || verdict == Verdict::kDoublePeak ||
                          verdict == Verdict::kTooWide || cut_light;
    if (evidence && scan.rejected) {
      scan.rejected->push_back(MakePoint(scan, peak, v, s.row[peak] - bg, s.row[peak], max_level));
      scan.rejected->back().cut = cut_light;
    }
    if (!CountVerdict(verdict, counts)) continue;
    Candidate c{s, v, peak, 0.0, 0.0, 0.0, s.row[peak], 0.0, 0.0};
    c.u = ReCentred(s, peak, bg, o, &c.bg, &c.mass, &c.variance, &c.window_centre);
    c.amplitude = s.row[peak] - c.bg;
    if (c.variance < o.min_variance_px2) {
      ++counts->too_narrow;
      if (scan.rejected)
        scan.rejected->push_back(MakePoint(scan, c.u, v, c.amplitude, s.row[peak], max_level));
      continue;
    }
    pending->push_back(c);
  }
  return lowest;
}

// Scans every line of the raster; line v is the mask's line `first_line` + v. Candidates settle
// in the order found, so the points come out in scan order.
void ScanLines(const Scan& scan,
               const RowMask& mask,
               int first_line,
               int max_level,
               const StripeOptions& options,
               std::vector<StripePoint>* out,
               StripeCounts* counts) {
  const Raster& r = scan.raster;
  struct Floor {
    int begin, end;
    std::uint16_t lowest;
  };
  std::vector<Floor> floors;
  std::vector<Candidate> pending;
  std::size_t settled = 0;
  const int lag = DirectionReach(options);
  const auto settle_before = [&](int line) {
    for (; settled < pending.size() && pending[settled].v < line; ++settled)
      Settle(pending[settled], scan, max_level, options, out, counts);
  };
  const auto mask_rows = mask.rows.begin() + first_line;  // mask_rows[v]: the mask of line v
  for (int v = 0; v < r.lines; ++v) {
    settle_before(v - lag);
    // Line v + 2 asked of memory while v and v + 1 are scanned: the hardware's prefetcher did not
    // keep up with the line's minimum alone (rows only: 1.1 -> 0.86 ms a full frame).
    if (v + 2 < r.lines) {
      const char* next = reinterpret_cast<const char*>(r.Line(v + 2));
      const int bytes = r.length * static_cast<int>(sizeof(std::uint16_t));
      for (int byte = 0; byte < bytes; byte += 64) __builtin_prefetch(next + byte);
    }
    for (const auto& [b, e] : mask_rows[v]) {
      ++counts->lines;
      const Span span{r.Line(v), std::max(0, b), std::min(r.length, e)};
      const std::uint16_t lowest = ScanSpan(span, scan, v, max_level, options, &pending, counts);
      if (scan.wanted) floors.push_back({span.begin, span.end, lowest});
    }
  }
  settle_before(r.lines);
  // A stripe lying along a line lifts the whole line: nothing along it stands out, but its floor
  // stands above the darkest line's. The column scan is wanted across such lines.
  std::uint16_t darkest = 0xffff;
  for (const Floor& f : floors) darkest = std::min(darkest, f.lowest);
  for (const Floor& f : floors) {
    if (f.lowest >= darkest + options.min_amplitude_dn) Want(scan, f.begin, f.end, 0);
  }
}

#if CV_SIMD128
// The 8 x 8 pixels at `in` (rows `in_stride` apart) transposed to `out` (rows `out_stride`
// apart): three rounds of interleaving, of 16-bit, 32-bit and 64-bit pieces.
void Transpose8x8(const std::uint16_t* in,
                  std::size_t in_stride,
                  std::uint16_t* out,
                  std::size_t out_stride) {
  using cv::v_uint16x8;
  using cv::v_uint32x4;
  v_uint16x8 r[8];
  for (std::size_t i = 0; i < 8; ++i) r[i] = cv::v_load(in + i * in_stride);
  v_uint16x8 t[8];  // t[2k], t[2k + 1]: rows 2k and 2k + 1 paired, columns 0-3 and 4-7
  for (std::size_t k = 0; k < 4; ++k) cv::v_zip(r[2 * k], r[2 * k + 1], t[2 * k], t[2 * k + 1]);
  v_uint32x4 q[8];  // q[0..3]: rows 0-3, column pairs (0,1) (2,3) (4,5) (6,7); q[4..7] rows 4-7
  for (std::size_t half = 0; half < 2; ++half) {
    const std::size_t at = 4 * half;
    cv::v_zip(cv::v_reinterpret_as_u32(t[at]), cv::v_reinterpret_as_u32(t[at + 2]), q[at],
              q[at + 1]);
    cv::v_zip(cv::v_reinterpret_as_u32(t[at + 1]), cv::v_reinterpret_as_u32(t[at + 3]), q[at + 2],
              q[at + 3]);
  }
  for (std::size_t pair = 0; pair < 4; ++pair) {
    const v_uint16x8 top = cv::v_reinterpret_as_u16(q[pair]);
    const v_uint16x8 bottom = cv::v_reinterpret_as_u16(q[pair + 4]);
    cv::v_store(out + 2 * pair * out_stride, cv::v_combine_low(top, bottom));
    cv::v_store(out + (2 * pair + 1) * out_stride, cv::v_combine_high(top, bottom));
  }
}
#endif

// out (width x height) = the transpose of in (height x width, rows `in_stride` apart). By hand
// because OpenCV's cv::transpose takes 3.3 ms on a full 2048 x 1536 16-bit frame here: 8 x 8
// blocks in registers (three rounds of interleaving), four of them down the input at a time so
// that each output row gets a whole cache line (32 pixels) at once. The turned probe's step
// was three quarters this transpose, pixel by pixel (issue 50: 6.3 -> 3.7 ms a full frame).
void Transpose(const std::uint16_t* in, int in_stride, int width, int height, std::uint16_t* out) {
  constexpr int kWide = 8, kTall = 32;
  const auto at = [](int row, int col, int stride) {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(stride) +
           static_cast<std::size_t>(col);
  };
  for (int y0 = 0; y0 < height; y0 += kTall) {
    const int rows = std::min(kTall, height - y0);
    for (int x0 = 0; x0 < width; x0 += kWide) {
      const int cols = std::min(kWide, width - x0);
      int done = 0;  // rows of this block transposed in registers
#if CV_SIMD128
      if (cols == kWide) {
        for (; done + kWide <= rows; done += kWide)
          Transpose8x8(in + at(y0 + done, x0, in_stride), static_cast<std::size_t>(in_stride),
                       out + at(x0, y0 + done, height), static_cast<std::size_t>(height));
      }
#endif
      for (int i = done; i < rows; ++i) {
        for (int j = 0; j < cols; ++j)
          out[at(x0 + j, y0 + i, height)] = in[at(y0 + i, x0 + j, in_stride)];
      }
    }
  }
}

// Rows [begin, end) of a mask's bitmap as spans.
std::vector<std::pair<int, int>> Spans(const std::uint8_t* bits, int length) {
  std::vector<std::pair<int, int>> spans;
  for (int i = 0; i < length;) {
    if (!bits[i]) {
      ++i;
      continue;
    }
    const int begin = i;
    while (i < length && bits[i]) ++i;
    spans.push_back({begin, i});
  }
  return spans;
}

// The smoothing along the stripe reaches 3 sigma each side.
int AlongKernelSize(double sigma_px) { return 2 * static_cast<int>(std::ceil(3.0 * sigma_px)) + 1; }

// The frame blurred by a Gaussian of sigma_x, sigma_y [px] over `kernel` (0 x 0: OpenCV's size
// for the sigmas) into *buffer, OpenCV, reflected borders.
const std::uint16_t* Blurred(const Frame& frame,
                             double sigma_x,
                             double sigma_y,
                             cv::Size kernel,
                             std::vector<std::uint16_t>* buffer) {
  buffer->resize(frame.pixels.size());
  const cv::Mat in(frame.aoi.height, frame.aoi.width, CV_16U,
                   const_cast<std::uint16_t*>(frame.pixels.data()));
  cv::Mat out(frame.aoi.height, frame.aoi.width, CV_16U, buffer->data());
  cv::GaussianBlur(in, out, kernel, sigma_x, sigma_y, cv::BORDER_REFLECT);
  return buffer->data();
}

// The frame blurred with a Gaussian of `sigma_px`, full-scale pixels kept at full scale.
const std::uint16_t* Smoothed(const Frame& frame,
                              double sigma_px,
                              int max_level,
                              std::vector<std::uint16_t>* buffer) {
  Blurred(frame, sigma_px, sigma_px, cv::Size(0, 0), buffer);
  for (size_t i = 0; i < buffer->size(); ++i) {
    if (frame.pixels[i] >= max_level) (*buffer)[i] = static_cast<std::uint16_t>(max_level);
  }
  return buffer->data();
}

// The frame blurred along one axis only (a stripe running down the image: along y); full
// scale only where the blur of full-scale pixels is.
const std::uint16_t* SmoothedAlong(const Frame& frame,
                                   double sigma_px,
                                   bool along_y,
                                   std::vector<std::uint16_t>* buffer) {
  const int k = AlongKernelSize(sigma_px);
  return along_y ? Blurred(frame, 0.0, sigma_px, cv::Size(1, k), buffer)
                 : Blurred(frame, sigma_px, 0.0, cv::Size(k, 1), buffer);
}

}  // namespace

RowMask RowMask::Full(const Aoi& aoi) {
  RowMask m;
  m.aoi = aoi;
  m.rows.assign(static_cast<size_t>(aoi.height), {{0, aoi.width}});
  return m;
}

std::size_t RowMask::PixelCount() const {
  std::size_t n = 0;
  for (const auto& row : rows) {
    for (const auto& [b, e] : row) n += static_cast<std::size_t>(e - b);
  }
  return n;
}

RowMask Transposed(const RowMask& mask) {
  const int w = mask.aoi.width, h = mask.aoi.height;
  RowMask t;
  t.aoi = {mask.aoi.y0, mask.aoi.x0, h, w};
  std::vector<std::uint8_t> bits(static_cast<std::size_t>(w) * static_cast<std::size_t>(h), 0);
  for (int y = 0; y < h && y < static_cast<int>(mask.rows.size()); ++y) {
    for (auto [b, e] : mask.rows[static_cast<size_t>(y)]) {
      for (int x = std::max(0, b); x < std::min(w, e); ++x)
        bits[static_cast<std::size_t>(x) * static_cast<std::size_t>(h) + y] = 1;
    }
  }
  t.rows.resize(static_cast<size_t>(w));
  for (int x = 0; x < w; ++x)
    t.rows[static_cast<size_t>(x)] = Spans(&bits[static_cast<std::size_t>(x) * h], h);
  return t;
}

StripeExtractor::StripeExtractor(const RowMask& mask, const StripeOptions& options)
    : mask_(mask), options_(options) {
  MLP_CHECK_EQ(mask_.rows.size(), static_cast<size_t>(std::max(0, mask_.aoi.height)));
  if (options_.axes != StripeAxes::kRows) column_mask_ = Transposed(mask_);
  const double along = options_.along_stripe_sigma_px;
  if (along > 0.0) {
    const cv::Mat kernel = cv::getGaussianKernel(AlongKernelSize(along), along, CV_64F);
    along_kernel_.assign(kernel.begin<double>(), kernel.end<double>());
  }
}

void StripeExtractor::Extract(const Frame& frame,
                              std::vector<StripePoint>* out,
                              StripeCounts* counts,
                              std::vector<StripePoint>* rejected) {
  const Aoi& a = frame.aoi;
  MLP_CHECK_MSG(mask_.aoi.width == a.width && mask_.aoi.height == a.height &&
                    mask_.aoi.x0 == a.x0 && mask_.aoi.y0 == a.y0 &&
                    frame.pixels.size() == base::RasterSize(a.width, a.height),
                "stripe: the mask's AOI must be the frame's");
  const int max_level = (1 << frame.bit_depth) - 1;
  const std::uint16_t* pixels = frame.pixels.data();
  if (options_.speckle_sigma_px > 0.0)
    pixels = Smoothed(frame, options_.speckle_sigma_px, max_level, &smoothed_);
  const double along = options_.along_stripe_sigma_px;
  const std::uint16_t* row_pixels =
      along > 0.0 ? SmoothedAlong(frame, along, true, &along_rows_) : pixels;
  const bool both = options_.axes == StripeAxes::kBoth;
  // Which columns the column scan reads: all when it runs alone; with both, those the row scan
  // marked (a stripe running down the image costs the column scan nothing).
  wanted_.assign(static_cast<size_t>(a.width), options_.axes == StripeAxes::kColumns ? 1 : 0);
  if (options_.axes != StripeAxes::kColumns) {
    Scan rows{{row_pixels, a.width, a.height}, ScanAxis::kRow, a.x0, a.y0, both};
    if (both) rows.wanted = &wanted_;
    rows.rejected = rejected;
    if (along > 0.0) WithUnsmoothed(pixels, a, 0, along_kernel_, &rows);
    const std::size_t first = out->size();
    ScanLines(rows, mask_, 0, max_level, options_, out, counts);
    UndoAlongBlur(out, first, along);
  }
  if (options_.axes == StripeAxes::kRows) return;
  const bool any_column =
      std::find(wanted_.begin(), wanted_.end(), std::uint8_t{1}) != wanted_.end();
  const std::uint16_t* unsmoothed = pixels;
  if (along > 0.0 && any_column) pixels = SmoothedAlong(frame, along, false, &along_columns_);
  for (int c0 = 0; c0 < a.width;) {
    if (!wanted_[static_cast<size_t>(c0)]) {
      ++c0;
      continue;
    }
    int c1 = c0;
    while (c1 < a.width && wanted_[static_cast<size_t>(c1)]) ++c1;
    // The band's columns transposed: the column scan's lines in memory order.
    transposed_.resize(static_cast<size_t>(c1 - c0) * static_cast<size_t>(a.height));
    Transpose(pixels + c0, a.width, c1 - c0, a.height, transposed_.data());
    Scan columns{{transposed_.data(), a.height, c1 - c0}, ScanAxis::kColumn, a.y0, a.x0 + c0, both};
    columns.rejected = rejected;
    if (along > 0.0) WithUnsmoothed(unsmoothed, a, c0, along_kernel_, &columns);
    const std::size_t first = out->size();
    ScanLines(columns, column_mask_, c0, max_level, options_, out, counts);
    UndoAlongBlur(out, first, along);
    c0 = c1;
  }
}

void ExtractStripe(const Frame& frame,
                   const RowMask& mask,
                   const StripeOptions& options,
                   std::vector<StripePoint>* out,
                   StripeCounts* counts) {
  StripeExtractor(mask, options).Extract(frame, out, counts);
}

}  // namespace mlp::probe_fw
