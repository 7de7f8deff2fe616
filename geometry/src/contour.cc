#include "mlp/geometry/contour.h"

#include <algorithm>
#include <vector>

namespace mlp::geometry {
namespace {

// The first step from below to at/above `level` along a line of n samples, refined to the
// centroid of the grey steps over the 7 steps around it (contour.h says why); -1 if there is
// no crossing.
double FirstCrossing(
    const GreyView& im, double level, int n, int fixed, bool along_row, bool falling = false) {
  // A falling edge is a rising one of the negated image about the level.
  const double sign = falling ? -1.0 : 1.0;
  const auto at = [&](int k) { return sign * (along_row ? im.At(k, fixed) : im.At(fixed, k)); };
  level *= sign;
  for (int k = 0; k + 1 < n; ++k) {
    if (!(at(k) < level && at(k + 1) >= level)) continue;
    // Signed steps: noise in the flat tails then adds nothing on average.
    double sum = 0, moment = 0;
    for (int j = std::max(0, k - 3); j <= std::min(n - 2, k + 3); ++j) {
      const double rise = at(j + 1) - at(j);
      sum += rise, moment += rise * (j + 0.5);
    }
    if (!(sum > 0)) return k + (level - at(k)) / (at(k + 1) - at(k));
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

Points2 RowCrossings(const GreyView& im, double level, bool falling) {
  std::vector<Vec2> out;
  for (int v = 0; v < im.height; ++v) {
    const double u = FirstCrossing(im, level, im.width, v, true, falling);
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
