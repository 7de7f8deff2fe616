#include "mlp/geometry/contour.h"

#include <algorithm>
#include <vector>

namespace mlp::geometry {
namespace {

// The first step from below to at/above `level` along a line of n samples, refined to the
// centroid of the grey level's rise over the 5 steps around it (for a symmetric blur the rise
// is symmetric about the edge; the threshold crossing alone is biased by the blur's curvature
// between two samples, ~0.02 px); -1 if there is no crossing.
double FirstCrossing(const GreyView& im, double level, int n, int fixed, bool along_row) {
  const auto at = [&](int k) { return along_row ? im.At(k, fixed) : im.At(fixed, k); };
  for (int k = 0; k + 1 < n; ++k) {
    if (!(at(k) < level && at(k + 1) >= level)) continue;
    double sum = 0, moment = 0;
    for (int j = std::max(0, k - 2); j <= std::min(n - 2, k + 2); ++j) {
      const double rise = at(j + 1) - at(j);
      if (rise <= 0) continue;
      sum += rise, moment += rise * (j + 0.5);
    }
    return moment / sum;
  }
  return -1.0;
}

Points2 ToPoints(const std::vector<Vec2>& v) {
  Points2 p(2, static_cast<Eigen::Index>(v.size()));
  for (size_t i = 0; i < v.size(); ++i) p.col(static_cast<Eigen::Index>(i)) = v[i];
  return p;
}

}  // namespace

Points2 RowCrossings(const GreyView& im, double level) {
  std::vector<Vec2> out;
  for (int v = 0; v < im.height; ++v) {
    const double u = FirstCrossing(im, level, im.width, v, true);
    if (u >= 0) out.emplace_back(u, v);
  }
  return ToPoints(out);
}

Points2 ColumnCrossings(const GreyView& im, double level) {
  std::vector<Vec2> out;
  for (int u = 0; u < im.width; ++u) {
    const double v = FirstCrossing(im, level, im.height, u, false);
    if (v >= 0) out.emplace_back(u, v);
  }
  return ToPoints(out);
}

}  // namespace mlp::geometry
