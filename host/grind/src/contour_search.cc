#include "mlp/grind/contour_search.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/grind/grind_frame.h"

#include <algorithm>
#include <cmath>

namespace mlp::grind {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw GrindError("grind point: " + what); }

struct Keyed {
  double key;  // the point's column (or row), mm
  Vec2 p;
};

// The contour sorted by column (or row), and its offsets from the line through C along u.
class SortedContour {
 public:
  SortedContour(const std::vector<Vec2>& contour, const Vec2& c, const Vec2& u, bool by_rows)
      : c_(c), w_(-u.y(), u.x()), by_rows_(by_rows) {
    for (const Vec2& p : contour) pts_.push_back({Key(p), p});
    std::sort(pts_.begin(), pts_.end(),
              [](const Keyed& a, const Keyed& b) { return a.key < b.key; });
  }
  // Columns grow with x; rows grow downwards (y up).
  double Key(const Vec2& p) const { return by_rows_ ? -p.y() : p.x(); }
  size_t size() const { return pts_.size(); }
  const Vec2& Point(size_t i) const { return pts_[i].p; }
  double Offset(size_t i) const { return (pts_[i].p - c_).dot(w_); }
  double Distance(size_t i) const { return std::abs(Offset(i)); }
  // The contour point in the column of `key` (the nearest key).
  size_t At(double key) const {
    const auto it = std::lower_bound(pts_.begin(), pts_.end(), key,
                                     [](const Keyed& a, double k) { return a.key < k; });
    size_t i = static_cast<size_t>(it - pts_.begin());
    if (i == pts_.size() || (i > 0 && key - pts_[i - 1].key < pts_[i].key - key)) --i;
    return i;
  }

 private:
  Vec2 c_, w_;
  bool by_rows_;
  std::vector<Keyed> pts_;
};

// From `from` one way along the sorted contour: stop once the distance to the line grows
// while its least so far is under a pixel; the point of the least distance.
size_t Directed(const SortedContour& s, size_t from, int step, double px_mm) {
  size_t i = from, best = from;
  for (;;) {
    const long next = static_cast<long>(i) + step;
    if (next < 0 || next >= static_cast<long>(s.size())) break;
    const auto n = static_cast<size_t>(next);
    if (s.Distance(n) > s.Distance(i) && s.Distance(best) < px_mm) break;
    i = n;
    if (s.Distance(i) < s.Distance(best)) best = i;
  }
  return best;
}

// Every point between two (the seed's cases 2 and 5): the least distance.
size_t Between(const SortedContour& s, size_t a, size_t b) {
  size_t best = std::min(a, b);
  for (size_t i = std::min(a, b); i <= std::max(a, b); ++i)
    if (s.Distance(i) < s.Distance(best)) best = i;
  return best;
}

// Mr to sub-pixel: a line through the contour points within 3 px of the one found, met with
// the line through C along u; the point itself when too few points make a line, or the two
// lines run nearly together.
double Refine(const SortedContour& s, size_t found, const Vec2& c, const Vec2& u, double px_mm) {
  std::vector<Vec2> near;
  for (size_t i = 0; i < s.size(); ++i)
    if ((s.Point(i) - s.Point(found)).norm() < 3 * px_mm) near.push_back(s.Point(i));
  if (near.size() >= 3) {
    geometry::Points2 local(2, static_cast<Eigen::Index>(near.size()));
    for (size_t k = 0; k < near.size(); ++k) local.col(static_cast<Eigen::Index>(k)) = near[k];
    try {
      const auto line = geometry::FitLine2(local);
      const Vec2 n(-line.shape.direction.y(), line.shape.direction.x());
      const double den = u.dot(n);
      if (std::abs(den) > 0.2) return (line.shape.point - c).dot(n) / den;
    } catch (const geometry::GeometryError&) {  // degenerate: the point found stands
    }
  }
  return (s.Point(found) - c).dot(u);
}

}  // namespace

LineCrossing FindContourOnLine(const std::vector<Vec2>& contour,
                               const Vec2& c,
                               const Vec2& mi,
                               double px_mm) {
  if (contour.empty()) Fail("no contour near Mi");
  const Vec2 u = (mi - c).normalized();
  LineCrossing out;
  out.by_rows = std::abs(u.x()) > std::abs(u.y());
  const SortedContour s(contour, c, u, out.by_rows);
  const double key_c = s.Key(c), key_mi = s.Key(mi);
  size_t found = 0;
  if (std::abs(key_c - key_mi) < 0.5 * px_mm) {
    found = s.At(key_c);  // the same column: its contour point
  } else {
    const size_t ic = s.At(key_c), im = s.At(key_mi);
    const double oc = s.Offset(ic), om = s.Offset(im);
    const bool c_after = key_c > key_mi;  // the seed's yC > yMi
    if (oc == 0 || om == 0 || (oc > 0) != (om > 0)) {
      out.seed_case = c_after ? 2 : 5;
      found = Between(s, ic, im);
    } else if (std::abs(oc) < std::abs(om)) {  // beyond C: on from yC, away from yMi
      out.seed_case = c_after ? 1 : 4;
      found = Directed(s, ic, c_after ? 1 : -1, px_mm);
    } else {  // beyond Mi: on from yMi, away from yC
      out.seed_case = c_after ? 3 : 6;
      found = Directed(s, im, c_after ? -1 : 1, px_mm);
    }
  }
  if (s.Distance(found) > 3 * px_mm) Fail("no contour on the line from C to Mi");
  out.t_mm = Refine(s, found, c, u, px_mm);
  return out;
}

}  // namespace mlp::grind
