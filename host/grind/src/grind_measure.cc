#include "mlp/grind/grind_measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"
#include "mlp/grind/contour_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

namespace mlp::grind {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw GrindError("grind point: " + what); }

// The after-frame's contour within `radius` of `near` (mm). Unordered: the search sorts it its
// own way (contour_search.h), and nothing else depends on the order.
std::vector<Vec2> Contour(const geometry::GreyView& im,
                          const GrindCamera& c,
                          const Vec2& near,
                          double radius) {
  const geometry::Points2 px = geometry::AllCrossings(im, geometry::HalfLevel(im));
  std::vector<Vec2> out;
  for (Eigen::Index i = 0; i < px.cols(); ++i) {
    const Vec2 p = c.ToMm(px.col(i));
    if ((p - near).norm() < radius) out.push_back(p);
  }
  return out;
}

// Grey at `mm` in `im`, or NaN outside it.
double GreyAt(const geometry::GreyView& im, const GrindCamera& cam, const Vec2& mm) {
  const Vec2 px = cam.ToPx(mm);
  if (px.x() < 0 || px.y() < 0 || px.x() >= cam.width_px - 1 || px.y() >= cam.height_px - 1)
    return std::numeric_limits<double>::quiet_NaN();
  return geometry::Bilinear(im, px);
}

// The material's edge along a line by its local contrast (issue 55): the seed's cell takes its
// frames with the wheel 8 mm above focus, and the nose's blurred shadow dims the back light over
// the freshly cut surface to about half (an outside renderer: 97 grey where the frame's half
// level is 108.5), so no global level finds that edge; its step is still sharp. Along
// p(t) = a + t u (mm, t in [t_from, t_to], material beyond the edge), sampled every quarter
// pixel: the steepest fall (the difference over +-1 px), the levels either side as straight lines
// through 3-10 px away from it evaluated there (the shadow's slope), the crossing of their mean
// nearest it, on the part of the line inside the image. NaN without a fall of `min_contrast`
// grey or with under 21 px of the line inside the image.
struct LineEdge {
  double t_mm = std::numeric_limits<double>::quiet_NaN();
  double contrast = 0.0;  ///< grey levels between the two sides at the edge
};

// Where a side's samples start [px from the edge along the line]: 3 px where the line crosses
// the edge square; where it crosses obliquely (the image's gradient at angle phi to u) the
// edge's blur along the line is 1 / cos(phi) as long, and so is the start. Read inside the blur,
// the levels pull the crossing towards the edge's middle grey (outside renderer, seed 9369
// point 2: a worn nose crossed at 54 deg, -1.08 um with 3 px, -0.05 um with 6). At most 10.
int ObliqueSideStartPx(const geometry::GreyView& im,
                       const GrindCamera& cam,
                       const Vec2& at_edge,
                       const Vec2& u) {
  const Vec2 dx(cam.mm_per_px, 0), dy(0, cam.mm_per_px);
  const Vec2 gradient(GreyAt(im, cam, at_edge + dx) - GreyAt(im, cam, at_edge - dx),
                      GreyAt(im, cam, at_edge + dy) - GreyAt(im, cam, at_edge - dy));
  const double cos_phi =
      gradient.allFinite() && gradient.norm() > 0 ? std::abs(gradient.dot(u)) / gradient.norm() : 1;
  return std::clamp(static_cast<int>(std::ceil(3.0 / std::max(cos_phi, 0.3) - 1e-6)), 3, 10);
}

// Where EdgeAlongLine reads the sides' levels: outside the edge's blur along the line
// (ObliqueSideStartPx: the measurement on C-Mi), or at 3-10 px whatever the crossing (the rays
// round the nose, whose tests compare ray with ray and new dark with the edge's contrast as read
// there: read further out an oblique edge's contrast grows, and a droplet's new dark on a
// top-of-stroke frame fell under the test's share, outside renderer seed 9524 point 7).
enum class SideLevels { kOutsideBlur, kAtThreePx };

LineEdge EdgeAlongLine(const geometry::GreyView& im,
                       const GrindCamera& cam,
                       const Vec2& a,
                       const Vec2& u,
                       double t_from,
                       double t_to,
                       double min_contrast,
                       SideLevels levels = SideLevels::kOutsideBlur) {
  const double step = cam.mm_per_px / 4;
  const int whole = static_cast<int>(std::floor((t_to - t_from) / step)) + 1;
  std::vector<double> g;
  g.reserve(static_cast<size_t>(std::max(whole, 0)));
  // The part of the line inside the image (one piece: the image is convex): a point near the
  // frame's border keeps the edges whose search reaches beyond it (seed 9022: a burr where the
  // frame ends was on rays that were dropped whole).
  double t_first = t_from;  // where the piece inside begins
  for (int i = 0; i < whole; ++i) {
    const double grey = GreyAt(im, cam, a + (t_from + i * step) * u);
    if (std::isfinite(grey)) {
      if (g.empty()) t_first = t_from + i * step;
      g.push_back(grey);
    } else if (!g.empty()) {
      break;
    }
  }
  const int n = static_cast<int>(g.size());
  constexpr int kQ = 4;  // samples a pixel
  if (n < 2 * 10 * kQ + 1) return {};
  const auto at = [&g](int i) { return g[static_cast<size_t>(i)]; };
  int best = -1;
  double steepest = 0;
  for (int i = 10 * kQ; i < n - 10 * kQ; ++i) {
    const double fall = at(i - kQ) - at(i + kQ);  // bright to dark
    if (fall > steepest) steepest = fall, best = i;
  }
  if (best < 0) return {};
  // A side's level at the edge: a straight line through 8 samples' worth (7 px) from where the
  // edge's blur along the line ends (ObliqueSideStartPx).
  const int start_px = levels == SideLevels::kAtThreePx
                           ? 3
                           : ObliqueSideStartPx(im, cam, a + (t_first + best * step) * u, u);
  const int near_px =
      std::max(3, std::min(start_px, std::min(best, n - 1 - best) / kQ - 7));  // the line's ends
  const auto side = [&](int sign) {
    double st = 0, sg = 0, stt = 0, stg = 0, m = 0;
    for (int k = near_px * kQ; k <= (near_px + 7) * kQ; ++k) {
      const double t = sign * k, v = at(best + sign * k);
      st += t, sg += v, stt += t * t, stg += t * v, ++m;
    }
    const double slope = (m * stg - st * sg) / (m * stt - st * st);
    return (sg - slope * st) / m;  // at the edge (t = 0)
  };
  const double bright = side(-1), dark = side(+1);
  LineEdge out;
  out.contrast = bright - dark;
  if (!(out.contrast >= min_contrast)) return out;
  const double level = (bright + dark) / 2;
  double found = std::numeric_limits<double>::quiet_NaN(), nearest = 1e300;
  for (int i = best - 3 * kQ; i < best + 3 * kQ; ++i) {
    const double y0 = at(i), y1 = at(i + 1);
    if (!(y0 >= level && y1 < level)) continue;
    const double cross = i + (y0 - level) / (y0 - y1);
    if (std::abs(cross - best) < nearest) nearest = std::abs(cross - best), found = cross;
  }
  out.t_mm = t_first + found * step;
  return out;
}

// Distance t along u from a (relative to C) back to the wheel's theoretical edge (a - t u on
// it), the root nearer zero; false when the line along u misses the section.
bool BackToEdge(const WheelSection& wheel, const Vec2& a, const Vec2& u, double* t) {
  const std::vector<double> roots = wheel.Crossings(a, -u);
  if (roots.empty()) return false;
  *t = *std::min_element(roots.begin(), roots.end(),
                         [](double x, double y) { return std::abs(x) < std::abs(y); });
  return true;
}

// Spread and mean of the points' distances along the direction at angle phi.
bool Along(const WheelSection& wheel,
           const std::vector<Vec2>& a,
           double phi,
           double* spread,
           double* mean) {
  const Vec2 u(std::cos(phi), std::sin(phi));
  double s = 0, s2 = 0;
  for (const Vec2& q : a) {
    double t = 0;
    if (!BackToEdge(wheel, q, u, &t)) return false;
    s += t, s2 += t * t;
  }
  const double n = static_cast<double>(a.size());
  *mean = s / n, *spread = std::sqrt(std::max(0.0, s2 / n - *mean * *mean));
  return true;
}

// An edge point this far (and 4 robust sigma) from the wheel's edge at the shift found is not
// the wheel's: a droplet, a burr, a chip (the edge's own noise is 0.2-0.5 um).
constexpr double kNuisanceMm = 0.003;

// The points the wheel's edge, shifted along `phi` by their distances' median, explains (the
// median: a droplet pulls the mean).
std::vector<Vec2> Explained(const WheelSection& wheel, const std::vector<Vec2>& edge, double phi) {
  const Vec2 u(std::cos(phi), std::sin(phi));
  std::vector<double> along, off;
  for (const Vec2& q : edge) {
    double t = 0;
    along.push_back(BackToEdge(wheel, q, u, &t) ? t : 1e300);
  }
  const double centre = geometry::Median(along);
  for (double t : along) off.push_back(std::abs(t - centre));
  const double limit = std::max(kNuisanceMm, 4 * 1.4826 * geometry::Median(off));
  std::vector<Vec2> kept;
  for (size_t k = 0; k < edge.size(); ++k)
    if (off[k] <= limit) kept.push_back(edge[k]);
  return kept;
}

// A shift of the nose explains its arc to the edge's noise (0.3 um): beyond this spread the
// nose itself changed (worn smaller, or not round) and a circle is fitted instead.
constexpr double kShiftSpreadMm = 0.001;

// Where the error's direction is not determined to this (its 3-sigma), the error is taken
// along the normal at the size the crossing on C-Mi measured, said so (`direction_determined`).
constexpr double kDirectionLimitDeg = 5.0;
// How many sigmas the direction's uncertainty must fit in the limit: at 2, about one direction
// in 60 the outside renderer's fresh sets called determined was beyond 5 deg (5.4 and 5.5 deg on
// 9250-9347); 3 as the other limits of a measurement that acts on a machine (a 0.3 % two-sided
// tail for a normal error), the rest said undetermined and taken along the normal.
constexpr double kDirectionSigmas = 3.0;

// The covariance from the residuals assumes each edge point's error its own, but neighbouring
// rays share pixels and the arc's cusps and form bend the residuals together: with lag-one
// correlation rho of the residuals in ray order, n points carry the information of
// n (1 - rho) / (1 + rho) (the effective sample size of an AR(1) series, Bayley & Hammersley
// 1946), so the variances grow by (1 + rho) / (1 - rho). On the outside renderer's fresh seeds
// the uninflated sigma called 3 of 74 directions determined that were 5.8-7.7 deg off (3-5 sigma).
double CorrelatedInflation(const std::vector<double>& residuals) {
  double lag0 = 0, lag1 = 0, previous = 0;
  for (size_t i = 0; i < residuals.size(); ++i) {
    const double r = residuals[i];
    lag0 += r * r;
    if (i > 0) lag1 += r * previous;
    previous = r;
  }
  constexpr double kMaxRho = 0.95;
  const double rho = lag0 > 0 ? std::clamp(lag1 / lag0, 0.0, kMaxRho) : 0.0;
  return (1 + rho) / (1 - rho);
}

// The error along the normal at the size the crossing on C-Mi measured, said so: the direction
// the removed region's edge gave is not determined.
void SayUndetermined(const Vec2& n, PointResult* res) {
  res->direction_determined = false;
  res->error_dir = n, res->error_mm = res->d_mm;
}

// The error vector found, with its covariance, is taken where its direction is determined to
// kDirectionLimitDeg at kDirectionSigmas; else SayUndetermined.
void TakeIfDetermined(const Vec2& error,
                      const Eigen::Matrix2d& cov,
                      const Vec2& n,
                      PointResult* res) {
  const double size = error.norm();
  if (!(size > 0) || !cov.allFinite() || !error.allFinite()) return;
  const Vec2 across(-error.y() / size, error.x() / size);
  res->direction_sigma_deg = std::sqrt(across.dot(cov * across)) / size * base::kDegPerRad;
  if (kDirectionSigmas * res->direction_sigma_deg <= kDirectionLimitDeg) {
    res->error_dir = error / size, res->error_mm = size;
    return;
  }
  SayUndetermined(n, res);
}

// The nose as a circle through the removed region's edge where it is the nose's arc (centre
// and radius free): its centre's shift plus its lost radius along the normal is the error at
// the cutting point (the real nose touches at C + shift - n (R - wear) = Mi + shift + n wear),
// with its covariance (the residuals' correlation along the arc counted); `ok` false with under
// 10 points on the arc or an arc too short to fit.
struct NoseCircle {
  bool ok = false;
  Vec2 error = Vec2::Zero();
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
  double radius_mm = 0, radius_sigma_mm = 0, rms_mm = 0;
};

NoseCircle FitNose(const WheelSection& wheel, const std::vector<Vec2>& edge, const Vec2& n) {
  std::vector<Vec2> arc;
  for (const Vec2& q : edge)
    if (wheel.NearestOnArc(q)) arc.push_back(q);
  NoseCircle out;
  if (arc.size() < 10) return out;
  geometry::Points2 pts(2, static_cast<Eigen::Index>(arc.size()));
  for (size_t k = 0; k < arc.size(); ++k) pts.col(static_cast<Eigen::Index>(k)) = arc[k];
  try {
    const auto circle = geometry::FitCircle2(pts);
    std::vector<double> residuals;
    residuals.reserve(arc.size());
    for (const Vec2& q : arc)
      residuals.push_back((q - circle.shape.center).norm() - circle.shape.radius);
    const Eigen::Matrix3d cov = circle.covariance.matrix * CorrelatedInflation(residuals);
    Eigen::Matrix<double, 2, 3> jac;  // d error / d (centre x, centre y, radius)
    jac << 1, 0, -n.x(), 0, 1, -n.y();
    out.error = circle.shape.center + n * (wheel.nose_radius_mm() - circle.shape.radius);
    out.cov = jac * cov * jac.transpose();
    out.radius_mm = circle.shape.radius, out.radius_sigma_mm = std::sqrt(cov(2, 2));
    out.rms_mm = circle.stats.rms;
    out.ok = out.error.allFinite() && out.error.norm() > 0 && out.cov.allFinite();
  } catch (const geometry::GeometryError&) {  // the arc too short
  }
  return out;
}

// A nose worn smaller: the circle's error, taken where the fit's covariance determines its
// direction (TakeIfDetermined: on a short arc the centre and the radius trade against each
// other). Without a circle the shift's answer stands.
void WornNose(const NoseCircle& nose, const Vec2& n, PointResult* res) {
  if (!nose.ok) return;
  res->nose_radius_mm = nose.radius_mm;
  res->spread_mm = nose.rms_mm;
  TakeIfDetermined(nose.error, nose.cov, n, res);
}

// A shift of the nose and a nose worn smaller leave nearly the same edge on an arc seen on one
// side of the normal (each stroke adds its new arc on the side it travels to), to well within
// kShiftSpreadMm: fitted as a shift, a worn R3 nose's error came out 14 deg off the normal
// (outside renderer seed 9633 point 0: 17 um lost, the circle's radius 3 sigma off by far;
// the circle put it 1.5 deg off). A radius this many sigmas from the wheel's is worn.
constexpr double kWornSigmas = 3.0;

// The wheel's shift by least squares over the removed region's edge (issue 55): each point's
// signed distance to the wheel's edge moved by the shift o is its residual; Gauss-Newton from
// the smallest spread's shift (numerical gradient of the section's distance), the covariance
// from the residuals. The seed's smallest spread leans to the normal once the edge carries
// 0.2-0.5 um of noise (3-15 deg on an outside renderer); least squares does not, but a short
// arc leaves the shift's part across the normal loose: where its direction's 3-sigma exceeds
// 5 deg the direction is not determined, and the error is taken along the normal at the size
// the crossing on C-Mi measured, said so (`direction_determined`).
void ShiftByLeastSquares(const WheelSection& wheel,
                         const std::vector<Vec2>& edge,
                         const Vec2& n,
                         PointResult* res) {
  Vec2 o = res->error_dir * res->error_mm;
  constexpr double kH = 1e-5;  // mm, for the gradient
  Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
  double ss = 0;
  for (int iter = 0; iter < 6; ++iter) {
    jtj.setZero();
    Eigen::Vector2d jtr = Eigen::Vector2d::Zero();
    ss = 0;
    for (const Vec2& q : edge) {
      const Vec2 p = q - o;
      const double r = wheel.SignedDistanceMm(p);
      const Vec2 grad(
          (wheel.SignedDistanceMm(p + Vec2(kH, 0)) - wheel.SignedDistanceMm(p - Vec2(kH, 0))) /
              (2 * kH),
          (wheel.SignedDistanceMm(p + Vec2(0, kH)) - wheel.SignedDistanceMm(p - Vec2(0, kH))) /
              (2 * kH));
      const Eigen::Vector2d jac = -grad;  // d r / d o
      jtj += jac * jac.transpose(), jtr += jac * r, ss += r * r;
    }
    const Eigen::Vector2d step = jtj.ldlt().solve(-jtr);
    if (!step.allFinite()) return;  // the smallest spread's answer stands
    o += step;
    if (step.norm() < 1e-7) break;
  }
  const double dof = std::max(1.0, static_cast<double>(edge.size()) - 2);
  std::vector<double> residuals;
  residuals.reserve(edge.size());
  for (const Vec2& q : edge) residuals.push_back(wheel.SignedDistanceMm(q - o));
  const Eigen::Matrix2d cov = jtj.inverse() * (ss / dof) * CorrelatedInflation(residuals);
  TakeIfDetermined(o, cov, n, res);
}

// The wheel's error found from the removed region's edge must agree with what the crossing on
// C-Mi measured: the error's part along the normal is the material left there (a shift s of
// the nose leaves s . n + |s x n|^2 / 2R along the normal; a worn nose, its lost radius), to
// the edge's noise and a share of d for the neglected terms. A droplet or a burr on the edge
// pulls the fit and not the crossing: 38-253 um at 135-150 deg from the normal where the
// crossing said 12 um (issue 55's outside renderer). And a nose fitted far from the wheel's
// radius is not the nose: refused, never compensated.
constexpr double kAgreeMm = 0.002, kAgreeShare = 0.25;
constexpr double kMaxNoseChange = 0.05;  // of the radius: a nose worn further is re-dressed

void CheckAgainstCrossing(const PointResult& res, const Vec2& n, double r, bool untouched_at_mi) {
  const double along = res.error_mm * res.error_dir.dot(n);
  // Where the stroke took nothing on C-Mi (the after edge there is the before's) the wheel fell
  // short of the stock the last pass left, so the material on C-Mi is that stock and the wheel
  // lies further off than it: the fit may exceed the crossing, never fall short of it (found
  // on the outside renderer: under-feeds of 7-15 um at up to 40 deg where the wheel was 12-24 um
  // off, refused as disagreeing though the fit was right within 2 deg and 1 um).
  if (untouched_at_mi && along >= res.d_mm - kAgreeMm - kAgreeShare * res.d_mm) return;
  const auto um = [](double mm) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f", mm * 1e3);
    return std::string(text);
  };
  if (!(std::abs(along - res.d_mm) <= kAgreeMm + kAgreeShare * res.d_mm))
    Fail("the removed region's edge puts the wheel " + um(res.error_mm) + " um off at " +
         std::to_string(std::lround(std::acos(std::clamp(res.error_dir.dot(n), -1.0, 1.0)) *
                                    base::kDegPerRad)) +
         " deg from the normal, " + um(along) + " um along it, where the contour on C-Mi left " +
         um(res.d_mm) +
         " um: something on the edge (a droplet, a burr) that no wheel position "
         "explains; not compensated");
  if (res.nose_radius_mm > 0 && !(std::abs(res.nose_radius_mm - r) <= kMaxNoseChange * r))
    Fail("the removed region's arc fits a nose of radius " + um(res.nose_radius_mm) +
         " um where the wheel's is " + um(r) +
         " um: not the nose (a droplet, a burr) or a "
         "wheel worn beyond 5 % of its radius; not compensated");
}

// A step of a fifth of the frame's grey range is an edge (the outside renderer's shadowed one
// is about 40 %, the noise 2-5 grey). Along C-Mi the edge is looked for from this far before
// Mi (material left: the previous pass's stock and more) to this far beyond it (an over-cut).
constexpr double kMinContrastShare = 0.2;
constexpr double kBeforeMiMm = 0.4, kBeyondMiMm = 0.4;

// The material's edge round the nose by local contrast (issue 55, as Mr): rays from C a pixel
// apart at the nose, within +-1 rad of C-Mi, each searched round where it meets the theoretical
// wheel's edge, in the after frame and the before; a ray whose edges are not both found is left
// out.
// Along each ray, the light side of the after edge is sampled every 2 px from 2 to 24 px before
// it (a feather burr stands 60-120 um on the edge) in both frames: before - after there is new
// dark, material the stroke cannot have made. Stored out to 48 px: a neighbouring ray whose edge
// lies further from C is read at the same distance from C (kSideSamples).
constexpr int kNewDarkSamples = 12, kSideSamples = 24;
constexpr double kNewDarkStepPx = 2.0;

using LightSide = std::array<double, kSideSamples>;

struct Ray {
  Vec2 dir;
  long k = 0;                          // its angle from C-Mi, in steps of a pixel at the nose
  double after_mm = 0, before_mm = 0;  // from C to the edge
  double contrast = 0;                 // the after edge's
  double step_mm = 0;                  // between the light side's samples
  LightSide new_dark{};                // before - after grey, light side
  LightSide after_dark{};              // minus the after frame's grey, light side
};

// The before frame's edge along the ray, or the window's start where the before frame is
// material all along it (the stroke took more than the window holds: an R6 wheel's corner far
// from Mi, seed 9022): there the light side of the after edge, 3 px before it, is over half the
// edge's contrast darker in the before frame. NaN otherwise.
double BeforeEdgeMm(const PointInput& in,
                    const GrindCamera& cam,
                    const Vec2& dir,
                    double from,
                    double to,
                    const LineEdge& after,
                    double min_contrast) {
  const LineEdge before =
      EdgeAlongLine(in.before, cam, in.c_mm, dir, from, to, min_contrast, SideLevels::kAtThreePx);
  if (std::isfinite(before.t_mm)) return before.t_mm;
  const Vec2 light = in.c_mm + (after.t_mm - 3 * cam.mm_per_px) * dir;
  const double darker = GreyAt(in.after, cam, light) - GreyAt(in.before, cam, light);
  return darker > after.contrast / 2 ? from : std::numeric_limits<double>::quiet_NaN();
}

std::vector<Ray> EdgeRays(const PointInput& in,
                          const GrindCamera& cam,
                          const WheelSection& wheel,
                          double min_contrast) {
  const double toward = std::atan2(in.mi_mm.y() - in.c_mm.y(), in.mi_mm.x() - in.c_mm.x());
  const double dphi = cam.mm_per_px / wheel.nose_radius_mm();
  std::vector<Ray> rays;
  for (double k = -std::floor(1.0 / dphi); k <= std::floor(1.0 / dphi); ++k) {
    const Vec2 dir(std::cos(toward + k * dphi), std::sin(toward + k * dphi));
    const std::vector<double> rim = wheel.Crossings(Vec2::Zero(), dir);  // C is inside it
    if (rim.empty() || !(rim.back() > 0)) continue;
    const double from = std::max(12 * cam.mm_per_px, rim.back() - kBeforeMiMm);
    const double to = rim.back() + kBeyondMiMm;
    const LineEdge after =
        EdgeAlongLine(in.after, cam, in.c_mm, dir, from, to, min_contrast, SideLevels::kAtThreePx);
    if (!std::isfinite(after.t_mm)) continue;
    const double before_mm = BeforeEdgeMm(in, cam, dir, from, to, after, min_contrast);
    if (!std::isfinite(before_mm)) continue;
    Ray ray{dir,
            static_cast<long>(k),
            after.t_mm,
            before_mm,
            after.contrast,
            kNewDarkStepPx * cam.mm_per_px,
            {},
            {}};
    for (int j = 0; j < kSideSamples; ++j) {
      const Vec2 at = in.c_mm + (after.t_mm - (j + 1) * kNewDarkStepPx * cam.mm_per_px) * dir;
      const double grey = GreyAt(in.after, cam, at);
      // Only darker counts: lighter is the stock the stroke took (or its edge's blur).
      ray.new_dark[static_cast<size_t>(j)] = std::max(0.0, GreyAt(in.before, cam, at) - grey);
      // In the region the stroke removed (beyond the before edge) only: elsewhere the light side
      // may graze a contour both frames share (a step at a cut's end, seed 5535).
      const bool removed =
          after.t_mm - (j + 1) * kNewDarkStepPx * cam.mm_per_px > before_mm + cam.mm_per_px;
      ray.after_dark[static_cast<size_t>(j)] =
          removed ? -grey : std::numeric_limits<double>::quiet_NaN();
    }
    rays.push_back(ray);
  }
  return rays;
}

// A droplet or a burr on the edge round the point (issue 55: found, not fitted). Along the rays
// the after edge is the first material from C: smooth pieces (the stock, each stroke's arc)
// meeting at corners, the cusps between strokes pointing at the wheel. A cusp is where the
// pieces either side meet; a droplet (10-30 um: 4-12 rays) or a feather burr (1-3 rays, 60-120
// um high) stands nearer C than both. So a ray whose edge lies over kBumpMm nearer C than the
// lines through the rays 8-20 either side both put it shows something on the edge (the edge's
// noise is 0.2-0.5 um); two such rays side by side (a droplet spans 4-12), or one over 4
// kBumpMm: the point's evidence is spoiled, refused with the reason, never compensated. Two
// rays apart are not counted together: on a top-of-stroke frame the edge read at a grazing
// 57 deg through the shadow's low contrast put single rays 3.3 and 3.2 um off, four rays apart
// (outside renderer seed 9633 point 1, refused clean).
constexpr double kBumpMm = 0.003;

// The straight line through rays [from, to] of `t` (by index), evaluated at `at`.
double LineAt(const std::vector<double>& t, long from, long to, long at) {
  double s = 0, sx = 0, sxx = 0, sy = 0, sxy = 0;
  for (long i = from; i <= to; ++i) {
    const double x = static_cast<double>(i - at), y = t[static_cast<size_t>(i)];
    s += 1, sx += x, sxx += x * x, sy += y, sxy += x * y;
  }
  const double slope = (s * sxy - sx * sy) / (s * sxx - sx * sx);
  return (sy - slope * sx) / s;
}

void RefuseBumps(const std::vector<Ray>& rays) {
  constexpr long kGap = 8, kFar = 20;
  std::vector<double> t;
  t.reserve(rays.size());
  for (const Ray& r : rays) t.push_back(r.after_mm);
  int run = 0, widest = 0;  // rays side by side (next angles) over kBumpMm
  double worst = 0;
  for (long i = kFar; i + kFar < static_cast<long>(t.size()); ++i) {
    const double sides =
        std::min(LineAt(t, i - kFar, i - kGap, i), LineAt(t, i + kGap, i + kFar, i));
    const double dip = sides - t[static_cast<size_t>(i)];
    const bool next =
        run > 0 && rays[static_cast<size_t>(i)].k == rays[static_cast<size_t>(i - 1)].k + 1;
    run = dip > kBumpMm ? (next ? run + 1 : 1) : 0;
    widest = std::max(widest, run);
    if (dip > kBumpMm) worst = std::max(worst, dip);
  }
  if (widest >= 2 || worst > 4 * kBumpMm)  // a feather burr is one ray wide, and tall
    Fail("something stands on the edge round the point (" + std::to_string(widest) +
         " rays side by side, up to " + std::to_string(std::lround(worst * 1e3)) +
         " um nearer the wheel than the contour either side: a droplet or a burr); not "
         "measured, not compensated");
}

// Something new on the light side of the after edge (issue 55: a feather burr, 7 um thick,
// standing on the edge): the after frame darker than the before where the stroke can only
// have taken material away. Against the same sample of the rays 4-10 either side (a shadow's
// shift between the frames, the back light's drift change slowly along the arc), a ray darker
// by over kNewDarkShare of its edge's contrast shows something; two such rays side by side, or
// one by twice that: refused with the reason, never compensated.
constexpr double kNewDarkShare = 0.25;

constexpr long kNewDarkNear = 4, kNewDarkFar = 10;

// Which of a ray's light-side samples a test reads.
using Darkness = LightSide Ray::*;

// The median over rays i + sign [kNewDarkNear, kNewDarkFar] of their samples at ray i's sample
// j's distance from C (not at the same distance from their own edges: the defocused wheel's
// shadow falls off with the distance from C, and where the edge leaves the wheel's circle, at a
// cut's end, the rays' edges part; read by their own edges, the rays past such a corner were
// 34 % darker than those before it, outside renderer seed 9633 point 0); NaN with under 3.
double SideLevel(const std::vector<Ray>& rays, Darkness dark, long i, long sign, size_t j) {
  const Ray& ray = rays[static_cast<size_t>(i)];
  std::vector<double> side;
  for (long k = kNewDarkNear; k <= kNewDarkFar; ++k) {
    const Ray& other = rays[static_cast<size_t>(i + sign * k)];
    const long at =
        static_cast<long>(j) + std::lround((other.after_mm - ray.after_mm) / ray.step_mm);
    if (at < 0 || at >= kSideSamples) continue;  // in its material, or past what it sampled
    const double v = (other.*dark)[static_cast<size_t>(at)];
    if (std::isfinite(v)) side.push_back(v);
  }
  return side.size() < 3 ? std::numeric_limits<double>::quiet_NaN() : geometry::Median(side);
}

// How far ray i's new dark stands above both sides' (a step along the arc, where the removed
// region ends or a shadow's edge lies, stands above one side only), as a share of its edge's
// contrast: the most over its samples.
double DarkShare(const std::vector<Ray>& rays, Darkness dark, long i) {
  double worst = 0;
  for (size_t j = 0; j < static_cast<size_t>(kNewDarkSamples); ++j) {
    const double left = SideLevel(rays, dark, i, -1, j), right = SideLevel(rays, dark, i, +1, j);
    const double v = (rays[static_cast<size_t>(i)].*dark)[j];
    if (!std::isfinite(left) || !std::isfinite(right) || !std::isfinite(v)) continue;
    worst = std::max(worst, (v - std::max(left, right)) / rays[static_cast<size_t>(i)].contrast);
  }
  return worst;
}

// The most any ray's darkness stands above both sides' (DarkShare), where it does so by over
// kNewDarkShare on two rays side by side or by twice that on one; 0 where none does.
double DarkStandingOut(const std::vector<Ray>& rays, Darkness dark) {
  const auto n = static_cast<long>(rays.size());
  bool previous = false;
  for (long i = kNewDarkFar; i + kNewDarkFar < n; ++i) {
    const double share = DarkShare(rays, dark, i);
    if (share > 2 * kNewDarkShare || (share > kNewDarkShare && previous)) return share;
    previous = share > kNewDarkShare;
  }
  return 0.0;
}

// The same test on the after frame alone: a burr standing where the stroke removed material
// (the before frame was dark there too, so before - after shows nothing: seed 8966 of the
// outside renderer, an R1 wheel's over-cut) is still a thin dark line crossing the light beside
// the new edge, darker than the same sample of the rays either side (the defocused wheel's
// shadow changes slowly along the arc).
void RefuseNewDark(const std::vector<Ray>& rays) {
  const auto refuse = [](double share, const std::string& against) {
    Fail("something stands in the light beside the edge round the point (the after frame " +
         std::to_string(std::lround(100 * share)) + " % of the edge's contrast darker than " +
         against + ": a burr or a droplet); not measured, not compensated");
  };
  const double new_dark = DarkStandingOut(rays, &Ray::new_dark);
  if (new_dark > 0) refuse(new_dark, "the before, where the stroke only takes material away");
  const double standing = DarkStandingOut(rays, &Ray::after_dark);
  if (standing > 0) refuse(standing, "beside it along the edge, where the stroke removed material");
}

// The part is solid beyond its edge: along C-Mi the after frame stays darker than the edge's
// half level for kSolidMm past the edge found (3 px on: the edge's blur). Light again within it,
// the first dark on the line is a speck in the light: a droplet thrown onto the line or a chip
// floating off the contour (10-60 um across), not the part; measured, it was an "under-feed"
// of 47 um where the wheel had gouged 443 um (outside renderer, seed 9166: an R1.5 wheel in a
// corner, a droplet on its circle in the light). Refused, never compensated.
constexpr double kSolidMm = 0.15;

// How far beyond the edge at `edge` the line is light again (past its half level), within
// kSolidMm; NaN where the edge is solid (or at the frame's border, not judged).
double LightAgain(const geometry::GreyView& after,
                  const GrindCamera& cam,
                  const Vec2& edge,
                  const Vec2& u) {
  const double px = cam.mm_per_px;
  const double light = GreyAt(after, cam, edge - 3 * px * u);
  const double dark = GreyAt(after, cam, edge + 3 * px * u);
  const double none = std::numeric_limits<double>::quiet_NaN();
  if (!std::isfinite(light) || !std::isfinite(dark)) return none;
  const double level = (light + dark) / 2;
  for (double s = 3 * px; s <= kSolidMm; s += px / 2) {
    const double grey = GreyAt(after, cam, edge + s * u);
    if (std::isfinite(grey) && grey > level) return s;
  }
  return none;
}

// Under-feed: where the wheel really was (seed 001, Fig. 4-6), from the removed region's edge.
// Whether the stroke took nothing along `u` (C to Mi): the ray nearest it (within kNearestRad)
// has its after edge within half a pixel of its before edge.
bool UntouchedAt(const std::vector<Ray>& rays, const Vec2& u, const GrindCamera& cam) {
  const Ray* nearest = nullptr;
  for (const Ray& ray : rays)
    if (!nearest || ray.dir.dot(u) > nearest->dir.dot(u)) nearest = &ray;
  constexpr double kNearestRad = 0.01;  // 10-60 um of arc on R1-6: at Mi, not beside it
  return nearest && nearest->dir.dot(u) > std::cos(kNearestRad) &&
         std::abs(nearest->after_mm - nearest->before_mm) <= 0.5 * cam.mm_per_px;
}

// The wheel's error from the removed region's edge: a nose worn (the shift's spread beyond
// kShiftSpreadMm, or the circle's radius off the wheel's) or a shift.
void ErrorFromEdge(const WheelSection& wheel,
                   const std::vector<Vec2>& edge,
                   const Vec2& n,
                   double best_spread,
                   PointResult* res) {
  const NoseCircle nose = FitNose(wheel, edge, n);
  const double worn_mm = wheel.nose_radius_mm() - nose.radius_mm;
  if (best_spread > kShiftSpreadMm ||
      (nose.ok && std::abs(worn_mm) > kWornSigmas * nose.radius_sigma_mm)) {
    WornNose(nose, n, res);
  } else {
    ShiftByLeastSquares(wheel, edge, n, res);
    // Nor does the circle rule out a nose worn by d: the shift's direction, where it leaves the
    // normal by over the limit, is one of two answers (outside renderer seeds 9627 point 3, 9637
    // point 4: worn R1.5 noses, the shift 7.7 and 8.1 deg off).
    if (nose.ok && res->direction_determined &&
        std::abs(worn_mm - res->d_mm) <= kWornSigmas * nose.radius_sigma_mm &&
        std::acos(std::clamp(res->error_dir.dot(n), -1.0, 1.0)) * base::kDegPerRad >
            kDirectionLimitDeg)
      SayUndetermined(n, res);
  }
}

// A point left out is something on the edge no wheel position explains: the error found
// without it is reported, but no compensation acts on it (outside renderer seed 9694 point 0:
// a feather burr, one edge point left out, compensated from the rest).
void WithholdIfLeftOut(PointResult* res) {
  if (res->left_out == 0) return;
  res->compensation_withheld = std::to_string(res->left_out) + " of " +
                               std::to_string(res->edge_points) +
                               " points on the removed region's edge off any wheel position (a "
                               "burr or a droplet on it?): measured, not compensated";
  res->compensation_mm = Vec2::Zero();
}

void UnderFeed(const std::vector<Ray>& rays,
               const Vec2& u,
               const GrindCamera& cam,
               const WheelSection& wheel,
               const Vec2& n,
               double e,
               PointResult* res) {
  // The removed region's edge: where the after frame's edge lies over half a pixel further
  // from C than the before frame's, the stroke removed material there (near the theoretical
  // wheel's edge).
  std::vector<Vec2> edge;
  for (const Ray& ray : rays) {
    if (!(ray.after_mm > ray.before_mm + 0.5 * cam.mm_per_px)) continue;
    const Vec2 q = ray.dir * ray.after_mm;  // relative to C
    if (wheel.SignedDistanceMm(q) < 4 * e + res->d_mm) edge.push_back(q);
  }
  res->edge_points = static_cast<int>(edge.size());
  if (edge.size() < 10) {  // the wheel did not cut: the normal and the excess, said so
    res->wheel_cut = false, res->direction_determined = false;
    res->compensation_mm = -n * res->d_mm;
    return;
  }
  const double normal = std::atan2(n.y(), n.x());
  double best = normal, best_spread = 1e300, best_mean = 0;
  const auto scan = [&](double from, double to, double step) {
    for (double phi = from; phi <= to + 1e-12; phi += step) {
      double spread = 0, mean = 0;
      if (Along(wheel, edge, phi, &spread, &mean) && spread < best_spread)
        best = phi, best_spread = spread, best_mean = mean;
    }
  };
  const auto smallest_spread = [&] {
    best = normal, best_spread = 1e300, best_mean = 0;
    scan(normal - M_PI / 2, normal + M_PI / 2, 0.5 / base::kDegPerRad);
    const double coarse = best;
    scan(coarse - 0.5 / base::kDegPerRad, coarse + 0.5 / base::kDegPerRad, 0.01 / base::kDegPerRad);
  };
  smallest_spread();
  // Nuisances found, not fitted (issue 55): a droplet or burr on the edge makes points no
  // wheel position explains; at the direction found, the points off the wheel's edge by more
  // than kNuisanceMm (and 4 robust sigma) leave, and the search runs again, until none leave.
  // Over a quarter left out: the evidence is spoiled (or the wheel is not the job's), refused.
  for (int round = 0; round < 3 && best_spread < 1e300; ++round) {
    const size_t before = edge.size();
    edge = Explained(wheel, edge, best);
    if (edge.size() == before) break;
    res->left_out += static_cast<int>(before - edge.size());
    if (edge.size() < 10 || 4 * res->left_out > res->edge_points)
      Fail("over a quarter of the removed region's edge is off any wheel position (" +
           std::to_string(res->left_out) + " of " + std::to_string(res->edge_points) +
           " points: a droplet, a burr, or not the job's wheel shape); not compensated");
    smallest_spread();
  }
  res->error_dir = Vec2(std::cos(best), std::sin(best));
  res->error_mm = best_mean, res->spread_mm = best_spread;
  res->seed_error_dir = res->error_dir, res->seed_error_mm = res->error_mm;
  ErrorFromEdge(wheel, edge, n, best_spread, res);
  CheckAgainstCrossing(*res, n, wheel.nose_radius_mm(), UntouchedAt(rays, u, cam));
  res->compensation_mm = -res->error_dir * res->error_mm;
  WithholdIfLeftOut(res);
}

// The edge's lens blur and bilinear reads: a found edge this close to the frame's last pixels
// is not measured.
constexpr double kFrameMarginPx = 2.0;

// Where no edge was found on C-Mi and Mi itself lies outside the frame, that is why: the
// operator learns the point is not in the camera's view (a job's point list or the camera's
// placement to check), not that the part has no contour there (outside renderer seed 9237:
// 7 points 2-79 px beyond the frame's right edge, each refused as "no contour on C-Mi"). The
// same for the edge found (`what` "Mr"): within `margin_px` of the frame's last pixels its
// blur and its interpolation reach past the frame (seed 9590 point 3: Mi and Mr 3 px beyond
// the right edge, the seed's search extrapolating the contour past the frame's last column,
// d 1.76 um off; Mi itself may lie outside where the edge found is inside).
void RefuseOutOfFrame(const GrindCamera& cam,
                      const Vec2& at_mm,
                      const char* what = "Mi",
                      double margin_px = 0) {
  const Vec2 px = cam.ToPx(at_mm);
  const std::array<double, 4> beyond = {margin_px - px.x(), px.x() - (cam.width_px - 1 - margin_px),
                                        margin_px - px.y(),
                                        px.y() - (cam.height_px - 1 - margin_px)};
  constexpr std::array<const char*, 4> kSide = {"left", "right", "top", "bottom"};
  const auto worst = std::max_element(beyond.begin(), beyond.end());
  if (!(*worst > 0)) return;
  const double out_px = *worst - margin_px;
  Fail(std::string(what) + " lies " +
       (out_px > 0 ? std::to_string(std::lround(out_px)) + " px beyond"
                   : "within " + std::to_string(std::lround(margin_px)) + " px of") +
       " the frame's " + kSide[static_cast<std::size_t>(worst - beyond.begin())] +
       " edge: the point is outside the camera's view, not measured");
}

}  // namespace

const char* ToString(Feed f) {
  switch (f) {
    case Feed::kGood:
      return "good";
    case Feed::kUnderFeed:
      return "under-feed";
    case Feed::kOverFeed:
      return "over-feed";
  }
  return "?";
}

// Past the window beyond Mi only the whole line's search or the seed's can find an edge, and
// on the outside renderer those were not always the gouge's (a wheel driven into a sharp corner:
// 462 um "under-feed" where no material lay within 0.6 mm). Such an edge at t is the gouge's
// bottom only where the after frame itself shows it on C-Mi: its steepest fall from light to
// dark within kConfirmMm of t, by the edge's contrast, lies within kConfirmPx of t, and the
// line from Mi to it is light all the way (no material in front of it). Measured then (issue
// 55: seed 9202's over-cuts of 404 and 478 um were refused though the seed's search had them
// within 0.3 um), else refused, never compensated. Beyond kDeepestMm nothing is measured: an
// over-cut that deep is a crash, not a compensation (the cell caps one at 0.1 mm), and the line
// from C there reaches past the wheel's nose into whatever lies beyond (outside renderer, seed
// 9424: an R6 wheel driven 0.6-0.9 mm into a corner, where the renderer itself says no material
// lies within 0.6 mm on C-Mi; with 1 mm those were measured as over-feeds).
constexpr double kConfirmMm = 0.15, kConfirmPx = 2.0, kDeepestMm = 0.6;

double ConfirmedDeepGouge(const PointInput& in,
                          const GrindCamera& cam,
                          const Vec2& u,
                          double ti,
                          double t,
                          double min_contrast) {
  const auto refuse = [&](const std::string& why) {
    Fail("the contour on C-Mi lies " + std::to_string(std::lround((t - ti) * 1e3)) +
         " um beyond Mi, past the " + std::to_string(std::lround(kBeyondMiMm * 1e3)) +
         " um searched, and " + why + ": not measured, not compensated");
  };
  if (t > ti + kDeepestMm)
    refuse("deeper than the " + std::to_string(std::lround(kDeepestMm * 1e3)) +
           " um a gouge is measured to");
  const LineEdge edge =
      EdgeAlongLine(in.after, cam, in.c_mm, u, t - kConfirmMm, t + kConfirmMm, min_contrast);
  if (!(std::abs(edge.t_mm - t) <= kConfirmPx * cam.mm_per_px))
    refuse("the frame shows no edge of the part there on C-Mi");
  const double half_level =
      GreyAt(in.after, cam, in.c_mm + (edge.t_mm - 10 * cam.mm_per_px) * u) - edge.contrast / 2;
  for (double s = ti; s < edge.t_mm - 3 * cam.mm_per_px; s += cam.mm_per_px) {
    if (!(GreyAt(in.after, cam, in.c_mm + s * u) > half_level))
      refuse("something dark lies on C-Mi before it");
  }
  return edge.t_mm;
}

// The first dark on C-Mi at `t` is a speck, light again `light_mm` beyond it: the part's edge is
// the next solid edge on the line past it, up to kDeepestMm beyond Mi, the line light from the
// speck's end to it (a droplet thrown into the light, or the defocused wheel's soft shadow, is
// passed over and said; outside renderer: seed 9166's droplet before a 443 um gouge, and
// over-cuts of 378-437 um where the shadow's edge came first, were refused). None, or another
// speck there: refused, never compensated.
double MaterialPastSpeck(const PointInput& in,
                         const GrindCamera& cam,
                         const Vec2& u,
                         double ti,
                         double t,
                         double light_mm,
                         double min_contrast) {
  const double px = cam.mm_per_px;
  const auto refuse = [&](const std::string& why) {
    Fail("the first material on C-Mi is a speck, light again " +
         std::to_string(std::lround(light_mm * 1e3)) +
         " um beyond its edge (a droplet or a chip off the contour, not the part), and " + why +
         "; not measured, not compensated");
  };
  const double from = t + light_mm;
  const LineEdge next =
      EdgeAlongLine(in.after, cam, in.c_mm, u, from + 3 * px, ti + kDeepestMm, min_contrast);
  if (!std::isfinite(next.t_mm)) refuse("no edge of the part beyond it on C-Mi");
  if (std::isfinite(LightAgain(in.after, cam, in.c_mm + next.t_mm * u, u)))
    refuse("the next dark beyond it is no solid edge either");
  // Nothing else falls to dark between them by the edges' own contrast rule (a level test
  // would take a soft shadow's slope for material: outside renderer, seed 9203).
  const LineEdge between =
      EdgeAlongLine(in.after, cam, in.c_mm, u, from, next.t_mm - 3 * px, min_contrast);
  if (std::isfinite(between.t_mm)) refuse("more dark lies between it and the next edge");
  return next.t_mm;
}

// The material's edge on C-Mi by its local contrast: in the window round Mi, else on the whole
// line from C (the seed's case 1), else past the window as deep as a gouge is measured, such an
// edge then confirmed as any past the window (ConfirmedDeepGouge). Outside renderer, seed 9369
// point 6: a 407 um over-cut, its edge straddling the window's end, was "no contour".
LineEdge EdgeOnCMi(
    const PointInput& in, const GrindCamera& cam, const Vec2& u, double ti, double min_contrast) {
  LineEdge on_line =
      EdgeAlongLine(in.after, cam, in.c_mm, u, std::max(12 * cam.mm_per_px, ti - kBeforeMiMm),
                    ti + kBeyondMiMm, min_contrast);
  if (!std::isfinite(on_line.t_mm))
    on_line = EdgeAlongLine(in.after, cam, in.c_mm, u, -ti, ti + kBeyondMiMm, min_contrast);
  if (!std::isfinite(on_line.t_mm))
    on_line = EdgeAlongLine(in.after, cam, in.c_mm, u, ti, ti + kDeepestMm, min_contrast);
  return on_line;
}

PointResult MeasurePoint(const PointInput& in,
                         const geometry::Profile2& nominal,
                         const GrindCamera& cam,
                         double r,
                         double e,
                         const WheelBevel& bevel) {
  if (in.after.width != cam.width_px || in.after.height != cam.height_px ||
      in.before.width != cam.width_px || in.before.height != cam.height_px)
    throw GrindInputError("grind point: a frame's size is not the camera's");
  if (!((in.c_mm - in.mi_mm).norm() > 0.5 * r))
    throw GrindInputError("grind point: C and Mi must be a wheel radius apart");
  const WheelSection wheel(r, bevel);
  const Vec2 u = (in.mi_mm - in.c_mm).normalized();
  const Vec2 n = nominal.Closest(in.mi_mm).normal;
  // Within two nose radii: the search reaches a radius beyond C (the seed's cases 1 and 4).
  const std::vector<Vec2> pts = Contour(in.after, cam, in.mi_mm, 2 * r);
  PointResult res;
  res.contour_mm = pts;
  const double ti = (in.mi_mm - in.c_mm).norm();
  // Mr: the material's edge on C-Mi by its local contrast (a shadowed frame, a steep flank whose
  // rows cross the other flank: issue 55); the seed's search on the half-level contour gives its
  // case, and Mr where the line shows no step.
  const double min_contrast = kMinContrastShare * (geometry::GreyPercentile(in.after, 0.98) -
                                                   geometry::GreyPercentile(in.after, 0.02));
  const LineEdge on_line = EdgeOnCMi(in, cam, u, ti, min_contrast);
  double t = on_line.t_mm;
  try {
    if (pts.size() < 10) Fail("no contour near Mi");
    const LineCrossing crossing = FindContourOnLine(pts, in.c_mm, in.mi_mm, cam.mm_per_px);
    res.search_case = crossing.seed_case, res.search_by_rows = crossing.by_rows;
    if (!std::isfinite(t)) t = crossing.t_mm;
  } catch (const GrindError&) {
    if (!std::isfinite(t)) {
      RefuseOutOfFrame(cam, in.mi_mm);
      throw;
    }
    res.search_case = -1;  // the seed's search found nothing: the local edge alone
  }
  res.local_edge = std::isfinite(on_line.t_mm);
  if (t > ti + kBeyondMiMm) t = ConfirmedDeepGouge(in, cam, u, ti, t, min_contrast);
  const double light_mm = LightAgain(in.after, cam, in.c_mm + t * u, u);
  if (std::isfinite(light_mm)) {
    const double speck_at = t;
    t = MaterialPastSpeck(in, cam, u, ti, t, light_mm, min_contrast);
    res.speck_passed_mm = t - speck_at;
  }
  res.mr_mm = in.c_mm + t * u;
  RefuseOutOfFrame(cam, res.mr_mm, "Mr", kFrameMarginPx);
  res.d_mm = std::abs(t - ti);
  res.feed = res.d_mm <= e ? Feed::kGood : t < ti ? Feed::kUnderFeed : Feed::kOverFeed;
  res.error_dir = n, res.error_mm = res.d_mm;
  const std::vector<Ray> rays = EdgeRays(in, cam, wheel, min_contrast);
  RefuseBumps(rays);
  RefuseNewDark(rays);
  if (res.feed == Feed::kOverFeed) res.compensation_mm = n * (res.d_mm + 2 * e);
  if (res.feed != Feed::kUnderFeed) return res;
  UnderFeed(rays, u, cam, wheel, n, e, &res);
  return res;
}

}  // namespace mlp::grind
