#include "mlp/probe_fw/along_blur.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <map>

namespace mlp::probe_fw {
namespace {

// Jacobi steps: each takes the neighbours' shift out once more (their slope carries it too);
// more than 3 changed the verify run's figures by < 1 um.
constexpr int kSteps = 3;
// A neighbour on the line `d` away is the same stripe when its centre lies within this of the
// point's [px]: the row scan owns a stripe crossing its lines at under 45 deg (slope < 1).
constexpr double kGateBasePx = 2.0;
constexpr double kGatePerLinePx = 1.0;
// The slope is fitted over the lines within 4 sigma of the kernel each side: the smoothed
// centres' speckle is correlated over about a sigma, so a shorter line sees it as slope (the
// outside renderer's speckled plane and cylinder: 11.26 / 9.64 um RMS at 2 sigma, 11.18 / 9.57
// at 4, 11.16 / 9.55 at 6).
constexpr double kReachSigmas = 4.0;
constexpr int kMinReachLines = 4;

// Per point, its neighbours on the lines within `reach` (one per line, the nearest within the
// gate): indices into the range, the line offset beside each.
struct Neighbour {
  std::size_t index;
  int offset_lines;
};

std::vector<std::vector<Neighbour>> Neighbours(const std::vector<StripePoint>& points,
                                               std::size_t begin,
                                               std::size_t end,
                                               int reach) {
  std::map<int, std::vector<std::size_t>> by_line;
  for (std::size_t i = begin; i < end; ++i) by_line[points[i].Line()].push_back(i);
  std::vector<std::vector<Neighbour>> out(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    const StripePoint& p = points[i];
    for (int d = -reach; d <= reach; ++d) {
      const auto it = by_line.find(p.Line() + d);
      if (it == by_line.end()) continue;
      const double gate = kGateBasePx + kGatePerLinePx * std::abs(d);
      std::size_t best = end;
      double best_gap = gate;
      for (std::size_t j : it->second) {
        const double gap = std::abs(points[j].Along() - p.Along());
        if (gap <= best_gap) best = j, best_gap = gap;
      }
      if (best != end) out[i - begin].push_back({best, d});
    }
  }
  return out;
}

// Slope [px/line] at offset 0 of centres `along` at line offsets: least squares in 1, k. A
// straight line, not a quadratic: the curvature's share (curvature/2 * M2, ~0.01 px on a
// sphere's arc) is below what a quadratic's noise under speckle adds to every centre (the
// outside renderer's speckled plane: 11.7 um RMS with it, 11.2 without). False below 3 lines.
bool Slope(const std::vector<Neighbour>& near,
           const std::vector<double>& along,
           std::size_t begin,
           double* slope) {
  // The straight line's slope in closed form (two unknowns: no solver needed per centre).
  if (near.size() < 3) return false;
  double n = 0.0, sk = 0.0, sx = 0.0, skk = 0.0, skx = 0.0;
  for (const Neighbour& m : near) {
    const double k = m.offset_lines, x = along[m.index - begin];
    n += 1.0, sk += k, sx += x, skk += k * k, skx += k * x;
  }
  const double spread = n * skk - sk * sk;
  if (!(spread > 0.0)) return false;
  *slope = (n * skx - sk * sx) / spread;
  return true;
}

void SetAlong(StripePoint* p, double along) {
  (p->axis == ScanAxis::kRow ? p->x_px : p->y_px) = along;
}

}  // namespace

void UndoAlongBlur(std::vector<StripePoint>* points, std::size_t begin, double sigma_px) {
  const std::size_t end = points->size();
  if (!(sigma_px > 0.0) || end <= begin) return;
  const int reach = std::max(kMinReachLines, static_cast<int>(std::ceil(kReachSigmas * sigma_px)));
  const auto near = Neighbours(*points, begin, end, reach);
  std::vector<double> blurred(end - begin), along(end - begin), next(end - begin);
  for (std::size_t i = begin; i < end; ++i) blurred[i - begin] = (*points)[i].Along();
  along = blurred;
  for (int step = 0; step < kSteps; ++step) {
    for (std::size_t i = begin; i < end; ++i) {
      const StripePoint& p = (*points)[i];
      double slope = 0.0;
      next[i - begin] = blurred[i - begin];
      if (Slope(near[i - begin], along, begin, &slope)) next[i - begin] -= slope * p.blur_m1_lines;
    }
    along.swap(next);
  }
  for (std::size_t i = begin; i < end; ++i) SetAlong(&(*points)[i], along[i - begin]);
}

}  // namespace mlp::probe_fw
