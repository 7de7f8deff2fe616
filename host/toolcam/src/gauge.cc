#include "mlp/toolcam/gauge.h"

#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

constexpr int kSectors = 1440;       // 0.25 deg: a CMM's even scan round the circle
constexpr int kRays = 2 * kSectors;  // edge points along the normal, two a sector
constexpr double kNearPx = 25.0;     // a circle's candidates: within this of it
constexpr double kLeaveOutPx = 3.0;  // and 4 robust sigma: burrs, hairs, dust
constexpr int kMinPointsPerCircle = 200;
constexpr double kMinCoverage = 0.9;  // of 5 deg sectors: the whole circle in view
constexpr long kCoverageSectors = 72;
constexpr size_t kFilterSectors = 15;  // of the 0.25 deg ones: a running median over 3.75 deg  // a
                                       // ring's edge in a gauge image has thousands

geometry::Circle2 LeastSquares(const std::vector<Vec2>& pts) {
  geometry::Points2 m(2, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = pts[i];
  return geometry::FitCircle2(m).shape;
}

// The radius round `centre` most of the points not yet taken lie at (a histogram's highest
// 4 px bin).
double MostCommonRadius(const std::vector<Vec2>& pts,
                        const Vec2& centre,
                        const std::vector<bool>& taken) {
  std::vector<int> histogram;
  for (size_t i = 0; i < pts.size(); ++i) {
    if (taken[i]) continue;
    const auto bin = static_cast<size_t>((pts[i] - centre).norm() / 4.0);
    if (bin >= histogram.size()) histogram.resize(bin + 1, 0);
    ++histogram[bin];
  }
  if (histogram.empty()) throw GaugeError("gauge: no second circle in the image");
  const auto top = std::max_element(histogram.begin(), histogram.end()) - histogram.begin();
  return 4.0 * (static_cast<double>(top) + 0.5);
}

// The profile's radii round `centre` through a running median over kFilterSectors (about 50
// undulations a turn pass, as ISO 12181-2's default filter for a part this size; a hair or a
// burr a few sectors wide does not): a roundness, a smallest or largest diameter as a CMM's
// filtered profile gives them, and a circle not pulled by the hairs.
std::vector<Vec2> Filtered(const std::vector<Vec2>& means, const Vec2& centre) {
  const size_t n = means.size();
  std::vector<double> r(n);
  for (size_t k = 0; k < n; ++k) r[k] = (means[k] - centre).norm();
  std::vector<Vec2> out(n);
  constexpr size_t kHalf = kFilterSectors / 2;
  for (size_t k = 0; k < n; ++k) {
    std::vector<double> w;
    for (size_t j = 0; j < 2 * kHalf + 1; ++j) w.push_back(r[(k + n + j - kHalf) % n]);
    out[k] = centre + (means[k] - centre).normalized() * geometry::Median(w);
  }
  return out;
}

// Even weight round the circle: each 0.25 deg sector's mean point round `centre`; refused
// when the points cover too little of the turn.
GaugedCircle SectorMeans(const std::vector<Vec2>& kept, const Vec2& centre) {
  GaugedCircle g;
  std::vector<Vec2> sum(kSectors, Vec2::Zero());
  std::vector<int> count(kSectors, 0);
  for (const Vec2& p : kept) {
    const double a = std::atan2(p.y() - centre.y(), p.x() - centre.x());
    const auto s = static_cast<size_t>(
        std::clamp(static_cast<int>((a + M_PI) / (2 * M_PI) * kSectors), 0, kSectors - 1));
    sum[s] += p, ++count[s];
  }
  for (size_t s = 0; s < sum.size(); ++s)
    if (count[s] > 0) g.sector_means_px.push_back(sum[s] / count[s]);
  g.sectors = static_cast<int>(g.sector_means_px.size());
  // Coverage in 5 deg sectors (a 0.25 deg one may hold no point where a crossing was lost):
  // an arc's diameter is not the part's.
  std::vector<bool> seen(kCoverageSectors, false);
  for (size_t s = 0; s < count.size(); ++s)
    if (count[s] > 0) seen[s * kCoverageSectors / count.size()] = true;
  const auto covered = std::count(seen.begin(), seen.end(), true);
  if (static_cast<double>(covered) < kMinCoverage * static_cast<double>(kCoverageSectors))
    throw GaugeError("gauge: a circle seen over " +
                     std::to_string(100 * covered / kCoverageSectors) +
                     " % of its turn; the whole part must be in the image");
  return g;
}

// The circle near radius `r0` round `c0`: its points within kNearPx, then least squares with
// the points over kLeaveOutPx (and 4 robust sigma) off left out, until the set stays.
GaugedCircle OneCircle(const std::vector<Vec2>& pts,
                       const Vec2& c0,
                       double r0,
                       std::vector<bool>* taken) {
  // The points near the circle so far (a first centre a few px off catches part of the ring
  // only), those off it by more than the limit left out, refitted until the set stays.
  geometry::Circle2 c{c0, r0};
  std::vector<size_t> near, kept_index;
  std::vector<Vec2> kept;
  for (int round = 0; round < 12; ++round) {
    near.clear();
    for (size_t i = 0; i < pts.size(); ++i)
      if (std::abs((pts[i] - c.center).norm() - c.radius) < kNearPx) near.push_back(i);
    if (near.size() < kMinPointsPerCircle)
      throw GaugeError("gauge: too few edge points on a circle");
    std::vector<double> off;
    off.reserve(near.size());
    for (size_t i : near) off.push_back(std::abs((pts[i] - c.center).norm() - c.radius));
    // The first round keeps the whole window: the circle is still the guess.
    const double limit =
        round == 0 ? kNearPx : std::max(kLeaveOutPx, 4 * 1.4826 * geometry::Median(off));
    std::vector<size_t> next;
    for (size_t k = 0; k < near.size(); ++k)
      if (off[k] <= limit) next.push_back(near[k]);
    if (next.size() < kMinPointsPerCircle)
      throw GaugeError("gauge: the circle's edge is mostly off a circle");
    const bool same = next == kept_index;
    kept_index = std::move(next);
    kept.clear();
    for (size_t i : kept_index) kept.push_back(pts[i]);
    c = LeastSquares(kept);
    if (same) break;
  }
  for (size_t i : near) (*taken)[i] = true;
  GaugedCircle g = SectorMeans(kept, c.center);
  g.points = static_cast<int>(kept.size());
  g.left_out = static_cast<int>(near.size() - kept.size());
  // The least-squares circle through every sector's mean, as a CMM's LS fit over its scan; the
  // filter below is for the form only (filtered, 20 parts' diameters moved 0.1 um RMS worse).
  const geometry::Circle2 even = LeastSquares(g.sector_means_px);
  g.centre_px = even.center, g.diameter_px = 2 * even.radius;
  g.sector_means_px = Filtered(g.sector_means_px, even.center);
  double lo = 1e300, hi = 0;
  for (const Vec2& m : g.sector_means_px) {
    const double r = (m - even.center).norm();
    lo = std::min(lo, r), hi = std::max(hi, r);
  }
  g.min_diameter_px = 2 * lo, g.max_diameter_px = 2 * hi, g.roundness_px = hi - lo;
  return g;
}

// The edge crossed along kRays normals of the circle found from the rows' and columns'
// crossings (within kNearPx of it): points as a CMM's scan takes them, one a direction, each
// found along the edge's own normal (geometry::CrossingAlongLine says why).
std::vector<Vec2> AlongNormals(const geometry::GreyView& image,
                               double level,
                               const GaugedCircle& found) {
  std::vector<Vec2> out;
  const double r = found.diameter_px / 2;
  for (int k = 0; k < kRays; ++k) {
    const double a = 2 * M_PI * (k + 0.5) / kRays;
    const Vec2 u(std::cos(a), std::sin(a));
    const double t =
        geometry::CrossingAlongLine(image, level, found.centre_px, u, r - kNearPx, r + kNearPx, r);
    if (std::isfinite(t)) out.push_back(found.centre_px + t * u);
  }
  return out;
}

// The circle again from its edge crossed along its normals.
GaugedCircle AlongNormalsCircle(const geometry::GreyView& image,
                                double level,
                                const GaugedCircle& found) {
  const std::vector<Vec2> pts = AlongNormals(image, level, found);
  std::vector<bool> taken(pts.size(), false);
  return OneCircle(pts, found.centre_px, found.diameter_px / 2, &taken);
}

}  // namespace

GaugedPart GaugeRing(const geometry::GreyView& image) {
  const double level = geometry::HalfLevel(image);
  const geometry::Points2 crossings = geometry::AllCrossings(image, level);
  std::vector<Vec2> pts;
  for (Eigen::Index i = 0; i < crossings.cols(); ++i) pts.push_back(crossings.col(i));
  if (pts.size() < size_t{2} * kMinPointsPerCircle)
    throw GaugeError("gauge: no part's edge in the image");
  std::vector<double> xs, ys;
  for (const Vec2& p : pts) xs.push_back(p.x()), ys.push_back(p.y());
  const Vec2 c0(geometry::Median(xs),
                geometry::Median(ys));  // dust is a few points; the ring's are thousands
  // The circle with the most points first (a ring's outer edge is the longer), then the
  // most common radius round its centre among the rest; named by size.
  std::vector<bool> taken(pts.size(), false);
  GaugedPart part;
  part.outer = OneCircle(pts, c0, MostCommonRadius(pts, c0, taken), &taken);
  part.inner = OneCircle(pts, part.outer.centre_px,
                         MostCommonRadius(pts, part.outer.centre_px, taken), &taken);
  if (part.inner.diameter_px > part.outer.diameter_px) std::swap(part.inner, part.outer);
  if (!(part.inner.diameter_px < part.outer.diameter_px) ||
      (part.inner.centre_px - part.outer.centre_px).norm() > 0.1 * part.inner.diameter_px)
    throw GaugeError("gauge: the two circles found are not a ring round one centre");
  part.stray_points = static_cast<int>(std::count(taken.begin(), taken.end(), false));
  part.outer = AlongNormalsCircle(image, level, part.outer);
  part.inner = AlongNormalsCircle(image, level, part.inner);
  return part;
}

GaugeScale FitGaugeScale(const std::vector<GaugedPart>& parts,
                         const std::vector<MasterFigures>& masters) {
  if (parts.size() != masters.size() || parts.size() < 2)
    throw GaugeError("gauge: the scale needs two masters or more, each with its CMM figures");
  const auto n = static_cast<Eigen::Index>(parts.size());
  Eigen::MatrixXd a(2 * n, 2);
  Eigen::VectorXd b(2 * n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const auto i = static_cast<size_t>(k);
    a.row(2 * k) << parts[i].outer.diameter_px, -2.0;  // the material larger by the bias
    b(2 * k) = masters[i].outer_diameter_mm;
    a.row(2 * k + 1) << parts[i].inner.diameter_px, 2.0;  // the hole smaller
    b(2 * k + 1) = masters[i].inner_diameter_mm;
  }
  const Eigen::Vector2d x = a.colPivHouseholderQr().solve(b);
  GaugeScale s;
  s.mm_per_px = x(0), s.edge_bias_mm = x(1);
  s.rms_mm = std::sqrt((a * x - b).squaredNorm() / static_cast<double>(2 * n));
  s.masters = static_cast<int>(n);
  const Eigen::Matrix2d cov =
      (a * x - b).squaredNorm() / static_cast<double>(2 * n - 2) * (a.transpose() * a).inverse();
  s.mm_per_px_u = std::sqrt(cov(0, 0)), s.edge_bias_u_mm = std::sqrt(cov(1, 1));
  s.correlation = cov(0, 1) / (s.mm_per_px_u * s.edge_bias_u_mm);
  return s;
}

namespace {

// d = k d_px + 2 sign b: the variance from k's and b's covariance, plus the masters' scatter.
double DiameterU(const GaugeScale& s, double d_px, double sign) {
  const double var = d_px * d_px * s.mm_per_px_u * s.mm_per_px_u +
                     4 * s.edge_bias_u_mm * s.edge_bias_u_mm +
                     4 * sign * d_px * s.correlation * s.mm_per_px_u * s.edge_bias_u_mm;
  return std::sqrt(std::max(var, 0.0) + s.rms_mm * s.rms_mm);
}

}  // namespace

PartFigures ToMillimetres(const GaugedPart& p, const GaugeScale& s) {
  const double k = s.mm_per_px, bias = 2 * s.edge_bias_mm;
  PartFigures f;
  f.outer_diameter_mm = k * p.outer.diameter_px - bias;
  f.outer_min_mm = k * p.outer.min_diameter_px - bias;
  f.outer_max_mm = k * p.outer.max_diameter_px - bias;
  f.inner_diameter_mm = k * p.inner.diameter_px + bias;
  f.inner_min_mm = k * p.inner.min_diameter_px + bias;
  f.inner_max_mm = k * p.inner.max_diameter_px + bias;
  f.outer_roundness_mm = k * p.outer.roundness_px;
  f.inner_roundness_mm = k * p.inner.roundness_px;
  f.outer_diameter_u_mm = DiameterU(s, p.outer.diameter_px, -1);
  f.inner_diameter_u_mm = DiameterU(s, p.inner.diameter_px, +1);
  f.centre_distance_mm = k * (p.outer.centre_px - p.inner.centre_px).norm();
  f.concentricity_mm = 2 * f.centre_distance_mm;
  return f;
}

}  // namespace mlp::toolcam
