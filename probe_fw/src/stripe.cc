#include "mlp/probe_fw/stripe.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mlp::probe_fw {
namespace {

struct Span {
  const std::uint16_t* row;  // the AOI row
  int begin, end;            // [begin, end) in AOI columns
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

// Centre of mass of intensity above `bg` in [centre - half, centre + half].
double Centroid(const Span& s, int centre, int half, double bg) {
  double mass = 0.0, moment = 0.0;
  for (int x = std::max(s.begin, centre - half); x <= std::min(s.end - 1, centre + half); ++x) {
    const double w = std::max(0.0, s.row[x] - bg);
    mass += w, moment += w * x;
  }
  return mass > 0.0 ? moment / mass : centre;
}

constexpr int kSkipBlock = 16;

std::uint16_t BlockMax(const std::uint16_t* p) {
  std::uint16_t m = 0;
  for (int k = 0; k < kSkipBlock; ++k) m = std::max(m, p[k]);
  return m;
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
  for (int x = std::max(s.begin, peak - reach); x <= std::min(s.end - 1, peak + reach); ++x) {
    const double v = s.row[x] - bg;
    saturated += s.row[x] >= max_level;
    above_half += v > 0.5 * amplitude;
    // A local maximum 3 px or more from the peak, and strong: a second stripe (reflection).
    const bool local_max =
        x > s.begin && x + 1 < s.end && s.row[x] >= s.row[x - 1] && s.row[x] >= s.row[x + 1];
    if (std::abs(x - peak) >= 3 && local_max && v > o.double_peak_ratio * amplitude) {
      return Verdict::kDoublePeak;
    }
  }
  if (saturated >= 2) return Verdict::kSaturated;
  if (above_half > o.max_width_px) return Verdict::kTooWide;
  return Verdict::kPoint;
}

void ScanSpan(const Span& s,
              const Frame& f,
              int y,
              const StripeOptions& o,
              std::vector<StripePoint>* out,
              StripeCounts* counts) {
  std::uint16_t lowest = 0xffff;
  for (int x = s.begin; x < s.end; ++x) lowest = std::min(lowest, s.row[x]);
  const double threshold_dn = lowest + o.min_amplitude_dn;
  // Integer threshold: a pixel is a candidate when row[x] >= threshold (same test as the real).
  const int threshold = static_cast<int>(std::ceil(threshold_dn));
  const int max_level = (1 << f.bit_depth) - 1;
  for (int x = s.begin; x < s.end;) {
    // Most of a row is background: skip it 16 pixels at a time (a vectorised maximum).
    if (x + kSkipBlock <= s.end && BlockMax(s.row + x) < threshold) {
      x += kSkipBlock;
      continue;
    }
    if (s.row[x] < threshold) {
      ++x;
      continue;
    }
    int run_end = x, peak = x;
    while (run_end < s.end && s.row[run_end] >= threshold) {
      if (s.row[run_end] > s.row[peak]) peak = run_end;
      ++run_end;
    }
    x = run_end;
    const double bg = LocalBackground(s, peak, o.window_half_px);
    switch (Judge(s, peak, bg, max_level, o)) {
      case Verdict::kWeak:
        ++counts->weak;
        continue;
      case Verdict::kSaturated:
        ++counts->saturated;
        continue;
      case Verdict::kDoublePeak:
        ++counts->double_peak;
        continue;
      case Verdict::kTooWide:
        ++counts->too_wide;
        continue;
      case Verdict::kCut:
        ++counts->cut;
        continue;
      case Verdict::kPoint:
        break;
    }
    // Re-centre the window once on the first estimate: removes the bias of a window that is
    // off-centre by up to half a pixel.
    const double first = Centroid(s, peak, o.window_half_px, bg);
    const int centre = std::clamp(static_cast<int>(std::lround(first)),
                                  s.begin + o.window_half_px + 2, s.end - o.window_half_px - 3);
    const double bg2 = LocalBackground(s, centre, o.window_half_px);
    const double x_aoi = Centroid(s, centre, o.window_half_px, bg2);
    const double amplitude = s.row[peak] - bg2;
    StripePoint p;
    p.x_px = x_aoi + f.aoi.x0;
    p.y_px = y + f.aoi.y0;
    p.amplitude_dn = amplitude;
    p.quality = std::clamp(amplitude / (0.5 * max_level), 0.0, 1.0);
    out->push_back(p);
    ++counts->points;
  }
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

void ExtractStripe(const Frame& frame,
                   const RowMask& mask,
                   const StripeOptions& options,
                   std::vector<StripePoint>* out,
                   StripeCounts* counts) {
  if (mask.aoi.width != frame.aoi.width || mask.aoi.height != frame.aoi.height ||
      mask.aoi.x0 != frame.aoi.x0 || mask.aoi.y0 != frame.aoi.y0) {
    throw std::invalid_argument("stripe: the mask's AOI differs from the frame's");
  }
  for (int y = 0; y < frame.aoi.height; ++y) {
    const std::uint16_t* row = frame.pixels.data() + static_cast<size_t>(y) * frame.aoi.width;
    for (const auto& [b, e] : mask.rows[static_cast<size_t>(y)]) {
      ++counts->rows;
      ScanSpan(Span{row, std::max(0, b), std::min(frame.aoi.width, e)}, frame, y, options, out,
               counts);
    }
  }
}

}  // namespace mlp::probe_fw
