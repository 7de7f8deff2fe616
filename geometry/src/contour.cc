#include "mlp/geometry/contour.h"

#include "mlp/geometry/columns.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace mlp::geometry {
namespace {

// The crossing between samples k and k + 1 of a line of n (`at` already signed so that it
// rises through `level` there), refined to the centroid of the grey steps over the 7 steps
// around it (contour.h says why).
template <typename At>
double Refine(const At& at, int k, int n, double level) {
  // Signed steps: noise in the flat tails then adds nothing on average.
  double sum = 0, moment = 0, rising = 0;
  for (int j = std::max(0, k - 3); j <= std::min(n - 2, k + 3); ++j) {
    const double rise = at(j + 1) - at(j);
    sum += rise, moment += rise * (j + 0.5), rising += std::max(rise, 0.0);
  }
  // Another edge inside the window (a thin gap of light before a drop, a second shadow):
  // its opposite steps cancel the rise and the centroid runs off. The crossing between the
  // two samples then (biased by hundredths of a pixel, but it stays on its edge).
  if (!(sum > 0.8 * rising)) return k + (level - at(k)) / (at(k + 1) - at(k));
  return moment / sum;
}

// The first step from below to at/above `level` along a line of n samples, refined; -1 if
// there is no crossing.
double FirstCrossing(
    const GreyView& im, double level, int n, int fixed, bool along_row, bool falling = false) {
  // A falling edge is a rising one of the negated image about the level.
  const double sign = falling ? -1.0 : 1.0;
  const auto at = [&](int k) { return sign * (along_row ? im.At(k, fixed) : im.At(fixed, k)); };
  level *= sign;
  for (int k = 0; k + 1 < n; ++k)
    if (at(k) < level && at(k + 1) >= level) return Refine(at, k, n, level);
  return -1.0;
}

// Every crossing of `level` along a line, either way, refined; appended as (u, v).
void LineCrossings(
    const GreyView& im, double level, int n, int fixed, bool along_row, std::vector<Vec2>* out) {
  const auto raw = [&](int k) { return along_row ? im.At(k, fixed) : im.At(fixed, k); };
  for (int k = 0; k + 1 < n; ++k) {
    const bool below = raw(k) < level, next_below = raw(k + 1) < level;
    if (below == next_below) continue;
    const double sign = below ? 1.0 : -1.0;
    const double c = Refine([&](int j) { return sign * raw(j); }, k, n, sign * level);
    out->push_back(along_row ? Vec2(c, fixed) : Vec2(fixed, c));
  }
}

}  // namespace

double GreyPercentile(const GreyView& im, double share) {
  std::array<long, 256> histogram{};
  for (int v = 0; v < im.height; ++v)
    for (int u = 0; u < im.width; ++u) ++histogram[static_cast<size_t>(im.At(u, v))];
  const double total = static_cast<double>(im.width) * im.height;
  long seen = 0;
  for (int g = 0; g < 256; ++g)
    if (static_cast<double>(seen += histogram[static_cast<size_t>(g)]) >= share * total) return g;
  return 255;
}

double HalfLevel(const GreyView& im) {
  return (GreyPercentile(im, 0.02) + GreyPercentile(im, 0.98)) / 2.0;
}

double Bilinear(const GreyView& im, const Vec2& px) {
  const int u = static_cast<int>(px.x()), v = static_cast<int>(px.y());
  const double fu = px.x() - u, fv = px.y() - v;
  return (1 - fv) * ((1 - fu) * im.At(u, v) + fu * im.At(u + 1, v)) +
         fv * ((1 - fu) * im.At(u, v + 1) + fu * im.At(u + 1, v + 1));
}

double CrossingAlongLine(const GreyView& im,
                         double level,
                         const Vec2& a,
                         const Vec2& u,
                         double t_from,
                         double t_to,
                         double t_near) {
  constexpr double kStepPx = 0.25;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto inside = [&im](const Vec2& p) {
    return p.x() >= 0 && p.y() >= 0 && p.x() < im.width - 1 && p.y() < im.height - 1;
  };
  if (!(t_to > t_from) || !inside(a + t_from * u) || !inside(a + t_to * u)) return nan;
  double found = nan, prev = Bilinear(im, a + t_from * u);
  for (double t = t_from + kStepPx; t <= t_to; t += kStepPx) {
    const double g = Bilinear(im, a + t * u);
    if ((prev < level) != (g < level)) {
      const double cross = t - kStepPx + kStepPx * (level - prev) / (g - prev);
      if (!(std::abs(cross - t_near) >= std::abs(found - t_near))) found = cross;
    }
    prev = g;
  }
  return found;
}

GreyView GreyView::Window(int u0, int v0, int w, int h) const {
  const int u_lo = std::clamp(u0, 0, width), v_lo = std::clamp(v0, 0, height);
  const int u_hi = std::clamp(u0 + w, u_lo, width), v_hi = std::clamp(v0 + h, v_lo, height);
  const int row = stride > 0 ? stride : width;
  return {pixels + static_cast<long>(v_lo) * row + u_lo, u_hi - u_lo, v_hi - v_lo, row};
}

Points2 RowCrossings(const GreyView& im, double level, bool falling) {
  std::vector<Vec2> out;
  for (int v = 0; v < im.height; ++v) {
    const double u = FirstCrossing(im, level, im.width, v, true, falling);
    if (u >= 0) out.emplace_back(u, v);
  }
  return AsColumns(out);
}

Points2 AllCrossings(const GreyView& im, double level) {
  std::vector<Vec2> out;
  for (int v = 0; v < im.height; ++v) LineCrossings(im, level, im.width, v, true, &out);
  for (int u = 0; u < im.width; ++u) LineCrossings(im, level, im.height, u, false, &out);
  return AsColumns(out);
}

Points2 ColumnCrossings(const GreyView& im, double level) {
  std::vector<Vec2> out;
  for (int u = 0; u < im.width; ++u) {
    const double v = FirstCrossing(im, level, im.height, u, false);
    if (v >= 0) out.emplace_back(u, v);
  }
  return AsColumns(out);
}

}  // namespace mlp::geometry
