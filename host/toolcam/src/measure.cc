#include "mlp/toolcam/measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/contour.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>

#include <Eigen/Dense>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw ToolError("tool measurement: " + what); }
[[noreturn]] void Bad(const std::string& what) {
  throw ToolInputError("tool measurement: " + what);
}

// The refusal rules (Refuse): at least this many outline points where the model expects the
// flank and end; a radius within 10 % and a tip within 1 mm of the model's (the tool file's
// own bounds on runout and an edge's length); the view's standard uncertainty of radius and
// tip within 5 um (an outline that fixes the edge gives ~0.1 um, tests/toolcam).
constexpr size_t kMinOutlinePoints = 20;
constexpr double kMaxRadiusChange = 0.1;
constexpr double kMaxTipChangeMm = 1.0;
constexpr double kMaxUncertaintyMm = 0.005;
// A helical flank slid along its helix looks the same: a fit can trade the edge's turn for
// its tip (the outside renderer's D2, 45 deg helix, seed 29006: the +y view's tip 231 um off
// at 13 deg of turn, rms 0.4 um; its -y view 2.6 um). Both flanks see one tip: beyond this
// (and three of their combined uncertainties) apart, the flute is refused, not averaged. The
// tuning corpus' largest honest disagreement is 15 um (seed 5106, its mean right to 1 um).
constexpr double kFlankTipsAgreeMm = 0.050;
// The underside's points within this above the end's shape: a square end's worn corner rises
// off the end (at 0.7 x a zero corner radius only points below the nominal end were used).
constexpr double kEndBandMm = 0.05;
// The flank's rows this close above a square end straddle it (the row's crossing lands
// anywhere along the partly covered end): not flank points.
constexpr double kEndRowMm = 0.005;
constexpr double kCornerReachMm = 0.02;
// A shadow this tall above a column's crossing is the tool's (the largest drop drawn or met
// in the corpora is 0.08 mm across).
constexpr double kEndRunMm = 0.12;
// The underside is fitted this far beyond where the other edges shade it (the fitted turn
// differs from the first guess by a few tenths of a degree).
constexpr double kOwnMarginMm = 0.01;
// How far above (else below) the reference height the helix' winding is checked.
constexpr double kWindingRiseMm = 0.6;

// Pixel -> tool frame, undoing the lens' radial distortion (the camera's calibration).

// The flank's extreme across at the reference height: the flank over the band round it
// smoothed by a quadratic in h, what sticks out beyond the contamination limit left out and
// the fit repeated (seed 000 example 3: drops and build-up there must not move the indexing;
// the median of a narrow band followed a drop as wide as half of it). NaN: too few points.
double ReferenceY(const std::vector<Vec2>& flank, const MeasureOptions& opt) {
  std::vector<Vec2> band;
  for (const Vec2& p : flank)
    if (std::abs(p.y() - opt.h_ref_mm) < opt.band_mm) band.push_back(p);
  std::vector<bool> keep(band.size(), true);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int round = 0; round < 8; ++round) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    int used = 0;
    for (size_t i = 0; i < band.size(); ++i) {
      if (!keep[i]) continue;
      const double t = (band[i].y() - opt.h_ref_mm) / opt.band_mm;
      const Eigen::Vector3d row(1, t, t * t);
      a += row * row.transpose(), b += row * band[i].x(), ++used;
    }
    if (used < 8) return std::nan("");
    c = a.ldlt().solve(b);
    bool changed = false;
    for (size_t i = 0; i < band.size(); ++i) {
      const double t = (band[i].y() - opt.h_ref_mm) / opt.band_mm;
      const bool out = band[i].x() - (c(0) + c(1) * t + c(2) * t * t) > opt.contamination_mm;
      if (keep[i] && out) keep[i] = false, changed = true;
    }
    if (!changed) break;
  }
  return std::isfinite(c(0)) ? c(0) : std::nan("");
}

// y -> -y: the -y flank as a +y flank (the model then reads the shadow's -y extent).
Outline Mirrored(const Outline& o) {
  Outline m;
  for (const Vec2& p : o.side_neg) m.side.emplace_back(-p.x(), p.y());
  for (const Vec2& p : o.bottom) m.bottom.emplace_back(-p.x(), p.y());
  for (const Vec2& p : o.bottom_open) m.bottom_open.emplace_back(-p.x(), p.y());
  return m;
}

// The outline points a flute's fit uses, each with the way "outside the model" points: the
// flank (+y) and the flat end (-h).
struct FitPoint {
  Vec2 p;
  bool side = true;
  bool active = true;
  double residual = 0;  ///< outward from the model [mm]
  FluteView::PointKind kind = FluteView::kUsed;
};

// The nominal tool (its edges true) shifted by (dy, dh) and turned: the reference model.
struct Model {
  ToolDescription tool;
  double turn0 = 0;  ///< the principal image's turn before the fitted correction
  bool fit_turn = false;

  double blur = 0;
  double tan_pitch = 0;  ///< the camera's (tool_camera.h): an edge's end seen at its depth
  int side = 1;          ///< -1: the -y flank, read mirrored

  double Reach(double h, double turn) const {
    const ShadowSpans s = tool.Shadow(h, turn, tan_pitch);
    if (s.count == 0) return 0.0;
    return side > 0 ? s.hi[s.count - 1] : -s.lo[0];
  }

  // The outline's flank at height h: the shadow's +y extent; with a pulse's blur, where half
  // the angles over the pulse reach (the half-grey edge of their average): their median.
  double Flank(double h, double turn) const {
    if (blur < 1e-4) return Reach(h, turn);
    std::array<double, 5> reach{};
    for (int b = 0; b < 5; ++b)
      reach[static_cast<size_t>(b)] = Reach(h, turn + blur * ((b + 0.5) / 5 - 0.5));
    std::nth_element(reach.begin(), reach.begin() + 2, reach.end());
    return reach[2];
  }

  // The outline's underside: for each y the lowest height whose shadow reaches it (the flat
  // end, then the corner's arc seen at the blade's angle). Tabulated as the flank every
  // 0.25 um of height from just below the tip through the corner (where the flank grows with
  // height), then read back by interpolation.
  struct Underside {
    std::vector<double> h, y;  ///< y non-decreasing
    double At(double yq) const {
      const auto it = std::lower_bound(y.begin(), y.end(), yq);
      if (it == y.begin()) return h.front();
      if (it == y.end()) return h.back();
      const auto i = static_cast<size_t>(it - y.begin());
      const double t = y[i] > y[i - 1] ? (yq - y[i - 1]) / (y[i] - y[i - 1]) : 1.0;
      return h[i - 1] + t * (h[i] - h[i - 1]);
    }
    // A height's distance from the underside at y times this is its distance normal to it:
    // cos of the underside's slope. Along h a steep stretch (a corner's arc turning upright,
    // the knee where another edge's corner takes over the silhouette) multiplied a few um
    // across into tens along h: a new torus cutter's end read as 50 um worn.
    double Normal(double yq) const {
      constexpr double kSpanMm = 0.002;
      const double dh_dy = (At(yq + kSpanMm) - At(yq - kSpanMm)) / (2 * kSpanMm);
      return 1.0 / std::sqrt(1.0 + dh_dy * dh_dy);
    }
  };

  Underside Tabulate(double turn) const {
    Underside u;
    constexpr double kStepMm = 0.00025;
    double running = 0;
    const double top_h = tool.EndHeight() + 0.05;
    for (double h = -0.05; h <= top_h; h += kStepMm) {
      running = std::max(running, Flank(h, turn));  // the underside sees the widest so far
      u.h.push_back(h), u.y.push_back(running);
    }
    return u;
  }

  // Outward residuals of every point for parameters x = (dy, dh, dturn): a flank point right
  // of the model, an underside point below it.
  void Residuals(const Eigen::Vector3d& x, std::vector<FitPoint>* pts) const {
    const double turn = turn0 + x(2);
    const Underside under = Tabulate(turn);
    for (FitPoint& f : *pts) {
      if (f.side)
        f.residual = f.p.x() - (Flank(f.p.y() - x(1), turn) + x(0));
      else
        f.residual = under.Normal(f.p.x() - x(0)) * ((under.At(f.p.x() - x(0)) + x(1)) - f.p.y());
    }
  }
};

// The normal matrix J^T J over the active points for the fitted parameters (the first n_par of
// dy, dh, dturn) and the gradient -J^T r, at x (numeric derivatives: the model's silhouette
// has no closed form once the helix turns the edge with height). Leaves the residuals at x.
struct Normal {
  Eigen::MatrixXd a;
  Eigen::VectorXd b;
};

Normal NormalAt(const Model& m, std::vector<FitPoint>* pts, const Eigen::Vector3d& x, int n_par) {
  m.Residuals(x, pts);
  std::vector<double> r0;
  for (const FitPoint& f : *pts) r0.push_back(f.residual);
  Eigen::MatrixXd jt = Eigen::MatrixXd::Zero(n_par, static_cast<Eigen::Index>(pts->size()));
  for (int k = 0; k < n_par; ++k) {
    Eigen::Vector3d xe = x;
    constexpr double eps = 1e-5;  // one step for the offsets [mm] and the turn [rad]
    xe(k) += eps;
    m.Residuals(xe, pts);
    for (size_t i = 0; i < pts->size(); ++i)
      jt(k, static_cast<Eigen::Index>(i)) = ((*pts)[i].residual - r0[i]) / eps;
  }
  Normal n{Eigen::MatrixXd::Zero(n_par, n_par), Eigen::VectorXd::Zero(n_par)};
  for (size_t i = 0; i < pts->size(); ++i) {
    (*pts)[i].residual = r0[i];
    if (!(*pts)[i].active) continue;
    const Eigen::VectorXd j = jt.col(static_cast<Eigen::Index>(i));
    n.a += j * j.transpose();
    n.b -= j * r0[i];
  }
  return n;
}

// Least squares over the active points (Gauss-Newton).
Eigen::Vector3d Fit(const Model& m, std::vector<FitPoint>* pts, Eigen::Vector3d x) {
  const int n_par = m.fit_turn ? 3 : 2;
  for (int it = 0; it < 30; ++it) {
    const Normal n = NormalAt(m, pts, x, n_par);
    const Eigen::VectorXd step = n.a.ldlt().solve(n.b);
    if (!step.allFinite()) Fail("the flute's outline does not determine its position");
    x.head(n_par) += step;
    if (step.norm() < 1e-8) break;
  }
  m.Residuals(x, pts);
  return x;
}

// Runs of consecutive points (in order along the outline) beyond `limit` one way.
template <class Visit>
void Runs(const std::vector<FitPoint>& pts,
          const std::vector<size_t>& order,
          double limit,
          bool outside,
          Visit visit) {
  size_t start = 0;
  bool in = false;
  for (size_t k = 0; k <= order.size(); ++k) {
    const bool off = k < order.size() &&
                     (outside ? pts[order[k]].residual > limit : pts[order[k]].residual < -limit);
    if (off && !in) start = k, in = true;
    if (!off && in) {
      visit(start, k);
      in = false;
    }
  }
}

struct Ordered {
  std::vector<size_t> side, bottom;  ///< side by h, bottom by y
};

Ordered Order(const std::vector<FitPoint>& pts) {
  Ordered o;
  for (size_t i = 0; i < pts.size(); ++i) (pts[i].side ? o.side : o.bottom).push_back(i);
  std::sort(o.side.begin(), o.side.end(),
            [&](size_t a, size_t b) { return pts[a].p.y() < pts[b].p.y(); });
  std::sort(o.bottom.begin(), o.bottom.end(),
            [&](size_t a, size_t b) { return pts[a].p.x() < pts[b].p.x(); });
  return o;
}

double Along(const FitPoint& f) { return f.side ? f.p.y() : f.p.x(); }

// Off the model beyond the finding limit: out of the reference fit. Also the findings (runs
// at least finding_length_mm long; outside runs shorter than contamination_length_mm are
// contamination, not build-up).
// A worn corner: the flank's lowest run and the end's outermost run inside the model, each
// too short to be a finding alone (a square corner worn to R 0.04 leaves ~0.02 mm off the
// model on each side, less the rows and columns that straddle the corner), are one finding
// at the corner when both are there and together half a finding's length.
struct CornerRuns {
  double length = 0, worst = 0, area = 0, h = 0, y = 0;
  std::vector<size_t> points;
  bool side = false, end = false;
};

void AddCornerFinding(const CornerRuns& c,
                      const MeasureOptions& o,
                      std::vector<FitPoint>* pts,
                      std::vector<Finding>* findings) {
  // Seen on both the flank and the end (contamination and noise are not), half the finding
  // length together: the rows and columns at the corner itself straddle it and leave.
  if (!(c.side && c.end) || c.length < 0.5 * o.finding_length_mm || c.worst < o.finding_mm) return;
  for (size_t i : c.points) (*pts)[i].kind = FluteView::kWear;
  Finding fd;
  fd.on_end = true, fd.corner = true;
  fd.h_mm = c.h, fd.y_mm = c.y;
  fd.length_mm = c.length, fd.max_mm = c.worst, fd.area_mm2 = c.area;
  findings->push_back(fd);
}

std::vector<Finding> Classify(std::vector<FitPoint>* pts, const MeasureOptions& o) {
  for (FitPoint& f : *pts) f.active = true, f.kind = FluteView::kUsed;
  std::vector<Finding> findings;
  const Ordered ord = Order(*pts);
  CornerRuns corner;
  for (const auto* line : {&ord.side, &ord.bottom}) {
    for (bool outside : {true, false}) {
      const double limit = outside ? o.contamination_mm : o.finding_mm;
      Runs(*pts, *line, limit, outside, [&](size_t a, size_t b) {
        const double from = Along((*pts)[(*line)[a]]), to = Along((*pts)[(*line)[b - 1]]);
        double worst = 0, area = 0;
        for (size_t k = a; k < b; ++k) {
          FitPoint& f = (*pts)[(*line)[k]];
          f.active = false;
          worst = std::max(worst, std::abs(f.residual));
          if (k + 1 < b)
            area += std::abs(f.residual) * std::abs(Along((*pts)[(*line)[k + 1]]) - Along(f));
        }
        const double length = std::abs(to - from);
        const bool contamination = outside && length < o.contamination_length_mm;
        const bool finding =
            !contamination && length >= o.finding_length_mm && worst >= o.finding_mm;
        for (size_t k = a; k < b; ++k)
          (*pts)[(*line)[k]].kind = !finding  ? FluteView::kContamination
                                    : outside ? FluteView::kBuildup
                                              : FluteView::kWear;
        // Reaching the corner: the flank's run from near its lowest point, the end's to near
        // its outermost (within kCornerReachMm: a few points there may sit on the model).
        const bool at_corner = *line == ord.side
                                   ? from - Along((*pts)[line->front()]) < kCornerReachMm
                                   : Along((*pts)[line->back()]) - to < kCornerReachMm;
        if (!finding && !outside && at_corner) {
          (*line == ord.side ? corner.side : corner.end) = true;
          corner.length += length, corner.area += area;
          corner.worst = std::max(corner.worst, worst);
          for (size_t k = a; k < b; ++k) corner.points.push_back((*line)[k]);
          if (*line == ord.side) corner.h = from;
          if (*line == ord.bottom) corner.y = to;
        }
        if (!finding) return;
        Finding fd;
        fd.buildup = outside;
        fd.on_end = *line == ord.bottom;
        const FitPoint& mid = (*pts)[(*line)[(a + b) / 2]];
        fd.h_mm = fd.on_end ? mid.p.y() : (from + to) / 2;
        fd.y_mm = fd.on_end ? (from + to) / 2 : 0.0;
        fd.length_mm = length, fd.max_mm = worst, fd.area_mm2 = area;
        findings.push_back(fd);
      });
    }
  }
  AddCornerFinding(corner, o, pts, &findings);
  return findings;
}

// The tool with its edges ground: no runout, no defects, no measured shape.
ToolDescription Ground(const ToolDescription& t) {
  ToolDescription g = t;
  for (auto& e : g.edges) e = CuttingEdge{};
  return g;
}

// Flank residuals binned every 0.01 mm of height, plus the model edge's own shape off the
// ground edge: the edge's measured shape.
std::vector<std::pair<double, double>> Profile(const std::vector<FitPoint>& pts,
                                               const ToolDescription& model,
                                               int edge) {
  constexpr double kBinMm = 0.01;
  std::map<long, std::pair<double, int>> bins;
  for (const FitPoint& f : pts) {
    if (!f.side || f.kind == FluteView::kContamination) continue;
    auto& b = bins[std::lround(f.p.y() / kBinMm)];
    b.first += f.residual, ++b.second;
  }
  const ToolDescription ground = Ground(model);
  std::vector<std::pair<double, double>> profile;
  for (const auto& [bin, sum] : bins) {
    const double h = static_cast<double>(bin) * kBinMm;
    const double own = model.EdgeRadius(edge, h) - ground.EdgeRadius(edge, h) -
                       model.edges[static_cast<size_t>(edge)].radial_offset_mm;
    profile.emplace_back(h, own + sum.first / sum.second);
  }
  return profile;
}

// The standard uncertainties (k = 1) of the view's radius and tip from the fit's covariance,
// s^2 (J^T J)^-1 with s the residuals' rms over n - p degrees of freedom (ISO/IEC Guide 98-3,
// least squares): what the outline determines. Infinite where it does not (a flank with no
// end in view leaves the tip free).
void Uncertainty(const Model& m,
                 std::vector<FitPoint>* pts,
                 const Eigen::Vector3d& x,
                 double sum_sq,
                 FluteView* v) {
  const int n_par = m.fit_turn ? 3 : 2;
  v->radius_u_mm = v->tip_u_mm = std::numeric_limits<double>::infinity();
  if (v->points <= n_par) return;
  const Normal n = NormalAt(m, pts, x, n_par);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(n.a);
  const double largest = eig.eigenvalues().maxCoeff(), smallest = eig.eigenvalues().minCoeff();
  if (!(smallest > 1e-12 * largest)) return;  // a direction the points do not see
  const Eigen::MatrixXd cov = n.a.inverse() * (sum_sq / (v->points - n_par));
  v->radius_u_mm = std::sqrt(cov(0, 0)), v->tip_u_mm = std::sqrt(cov(1, 1));
}

// A view the evidence does not support is refused, never reported: most of its outline off
// the model (not this tool's shape, or not the tool), a radius or tip far from the model's
// (the file bounds runout to 10 % of the radius and an edge's length to 1 mm), or a position
// the outline does not determine.
void Refuse(const FluteView& v,
            const Eigen::Vector3d& x,
            int offered,
            const ToolDescription& model,
            const std::string& name) {
  const auto um = [](double mm) {
    char text[32];
    std::snprintf(text, sizeof text, "%.1f um", mm * 1000);
    return std::string(text);
  };
  if (2 * v.points < offered)
    Fail(name + ": only " + std::to_string(v.points) + " of " + std::to_string(offered) +
         " outline points lie on the model (the rest off it by more than the contamination "
         "or finding limit): the images do not show this tool's shape");
  if (std::abs(x(0)) > kMaxRadiusChange * model.Radius())
    Fail(name + ": radius " + um(x(0)) + " from the model's, beyond 10 % of the radius");
  if (std::abs(x(1)) > kMaxTipChangeMm)
    Fail(name + ": tip " + um(x(1)) + " from the model's, beyond 1 mm");
  if (!(v.radius_u_mm <= kMaxUncertaintyMm && v.tip_u_mm <= kMaxUncertaintyMm))
    Fail(name + ": the outline does not determine the edge (u(radius) " + um(v.radius_u_mm) +
         ", u(tip) " + um(v.tip_u_mm) + ", limit " + um(kMaxUncertaintyMm) + ")");
}

// How far across the view's side the other edges (and the web) shade the end's band up to
// `top_mm` with the tool turned `turn`: beyond it the underside is edge `edge`'s alone.
double OthersReach(const ToolDescription& model,
                   int edge,
                   double turn,
                   int side,
                   double top_mm,
                   double tan_pitch) {
  ToolDescription others = model;
  others.edges[static_cast<size_t>(edge)].radial_offset_mm = -2 * model.Radius();  // nowhere
  double reach = 0;
  constexpr int kSteps = 8;
  for (int i = 0; i <= kSteps; ++i) {
    const ShadowSpans s = others.Shadow(top_mm * i / kSteps, turn, tan_pitch);
    if (s.count > 0) reach = std::max(reach, side > 0 ? s.hi[s.count - 1] : -s.lo[0]);
  }
  return reach;
}

// The outline's points the view fits: the flank above the end's shape, the underside in the
// end's band (`open_end`: with the columns light at the top, Outline::bottom_open).
std::vector<FitPoint> ViewPoints(
    const Outline& o, const ToolDescription& model, int edge, const Model& m, bool open_end) {
  const double r = model.Radius();
  // Where the end is rounded or pointed the outline is neither upright nor level: the flank
  // above it, the underside below it.
  const double rc = model.EndHeight();
  std::vector<FitPoint> pts;
  for (const Vec2& p : o.side)  // the flank, above the corner's flat part
    if (p.y() > 0.6 * rc + kEndRowMm && p.y() < model.flute_length_mm) pts.push_back({p, true});
  // The end and the corner, where the outline is not upright; outside the web, whose end is
  // the longest edge's (a small tool's end shows it, seed 000 example 1): there the facing
  // edge alone makes the underside.
  // Nor where another edge shades the end's band: there the longest edge's end is the
  // underside (a neighbour 6 um longer was read as 5 um of build-up on a new tool).
  const double band_mm = 0.7 * rc + kEndBandMm;
  const double own_from =
      std::max(model.core_ratio * r,
               OthersReach(model, edge, m.turn0, m.side, band_mm, m.tan_pitch) + kOwnMarginMm);
  std::vector<const std::vector<Vec2>*> bottoms = {&o.bottom};
  if (open_end) bottoms.push_back(&o.bottom_open);
  for (const auto* bottom : bottoms)
    for (const Vec2& p : *bottom)
      if (p.x() > own_from && p.x() < r - 0.1 * rc && p.y() < band_mm) pts.push_back({p, false});
  return pts;
}

// One edge in one principal image against `model`'s edge `edge` (facing the view's side at
// the reference height when the tool has turned turn0); `o` mirrored for the -y side.
FluteView MeasureView(const Outline& o,
                      const ToolDescription& model,
                      int edge,
                      double turn0,
                      int side,
                      const MeasureOptions& opt,
                      double pitch_deg,
                      const std::string& name,
                      bool open_end = false) {
  Model m;
  m.tool = model;
  m.turn0 = turn0;
  m.side = side;
  m.blur = opt.blur_rad;
  m.tan_pitch = std::tan(pitch_deg / base::kDegPerRad);
  m.fit_turn = model.helix_deg >= 5.0;  // a straight flute's turn trades with its radius
  std::vector<FitPoint> pts = ViewPoints(o, model, edge, m, open_end);
  if (pts.size() < kMinOutlinePoints)
    Fail(name + ": " + std::to_string(pts.size()) +
         " outline points where the model expects the flank and end, under " +
         std::to_string(kMinOutlinePoints) + " (is the tool in view?)");
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  FluteView v;
  v.side = side;
  for (int round = 0; round < opt.rounds; ++round) {
    x = Fit(m, &pts, x);
    v.findings = Classify(&pts, opt);
  }
  const CuttingEdge& e = model.edges[static_cast<size_t>(edge)];
  v.radius_mm = model.Radius() + e.radial_offset_mm + x(0);
  v.tip_h_mm = model.TipH(edge) + x(1);
  double ss = 0;
  for (const FitPoint& f : pts) {
    if (!f.active) {
      ++v.removed;
      continue;
    }
    ss += f.residual * f.residual;
    ++v.points;
  }
  v.rms_mm = v.points > 0 ? std::sqrt(ss / v.points) : 0.0;
  Uncertainty(m, &pts, x, ss, &v);
  Refuse(v, x, static_cast<int>(pts.size()), model, name);
  // Back in the tool frame: the -y side's points and model were read mirrored.
  for (const FitPoint& f : pts)
    v.points_yh.emplace_back(side * f.p.x(), f.p.y()), v.point_kind.push_back(f.kind);
  for (Finding& fd : v.findings) fd.y_mm *= side;
  v.profile = Profile(pts, model, edge);
  // The fitted model's outline: the flank down to the corner, then the underside inwards.
  const double turn = m.turn0 + x(2);
  for (double h = opt.h_ref_mm + 1.0; h >= 0.3 * model.EndHeight(); h -= 0.01)
    v.model_yh.emplace_back(side * (m.Flank(h, turn) + x(0)), h + x(1));
  const auto under = m.Tabulate(turn);
  for (size_t i = under.h.size(); i-- > 0;)
    if (under.y[i] > 0) v.model_yh.emplace_back(side * (under.y[i] + x(0)), under.h[i] + x(1));
  return v;
}

// The eccentricity of the edges' radii round the tool: r_k = r0 + a cos(phi_k) + b sin(phi_k).
void Eccentricity(ToolMeasurement* t) {
  const auto n = static_cast<Eigen::Index>(t->flutes.size());
  if (n < 3) return;
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd r(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double phi = t->flutes[static_cast<size_t>(k)].angle_deg / base::kDegPerRad;
    a.row(k) << 1, std::cos(phi), std::sin(phi);
    r(k) = t->flutes[static_cast<size_t>(k)].radius_mm;
  }
  const Eigen::Vector3d c = a.colPivHouseholderQr().solve(r);
  t->eccentricity_mm = std::hypot(c(1), c(2));
  t->eccentricity_deg = std::atan2(c(2), c(1)) * base::kDegPerRad;
}

// The frames' outlines and reference extremes (per side: +y, and -y read mirrored), in
// angular order; `top[s]` the image whose outline on side s reaches farthest at the reference
// height (`order.size()`: that side not in view).
struct IndexedImages {
  std::vector<Outline> outlines[2];  ///< [0] as found, [1] mirrored (its side the -y flank)
  std::vector<double> ref[2];
  std::vector<size_t> order;
  std::vector<double> angle_deg;
  std::vector<double> blur_rad;  ///< each image's pulse
  size_t top[2] = {0, 0};
  bool both = false;  ///< the -y flank shows at the reference height in enough images
};

int SideIndex(int side) { return side > 0 ? 0 : 1; }

// Each frame's angle [deg]: measured where the series has it, else its strobe position's.
std::vector<double> SeriesAnglesDeg(const ToolSeries& s) {
  if (s.angle_deg != nullptr && !s.angle_deg->empty()) return *s.angle_deg;
  std::vector<double> deg;
  for (int p : s.positions) deg.push_back(p * 360.0 / s.position_count);
  return deg;
}

// The options for a view in image i: its own pulse.
MeasureOptions InImage(const IndexedImages& x, size_t i, const MeasureOptions& opt) {
  MeasureOptions o = opt;
  o.blur_rad = x.blur_rad[i];
  return o;
}

IndexedImages IndexImages(const ToolSeries& series, const MeasureOptions& opt) {
  IndexedImages x;
  int neg = 0;
  for (const auto& f : series.frames) {
    x.outlines[0].push_back(ExtractOutline(f, series.camera));
    x.outlines[1].push_back(Mirrored(x.outlines[0].back()));
    x.ref[0].push_back(ReferenceY(x.outlines[0].back().side, opt));
    x.ref[1].push_back(ReferenceY(x.outlines[1].back().side, opt));
    if (std::isfinite(x.ref[1].back())) ++neg;
  }
  x.both = 2 * neg > static_cast<int>(series.frames.size());
  x.order.resize(series.frames.size());
  for (size_t i = 0; i < x.order.size(); ++i) x.order[i] = i;
  x.angle_deg = SeriesAnglesDeg(series);
  std::sort(x.order.begin(), x.order.end(),
            [&](size_t a, size_t b) { return x.angle_deg[a] < x.angle_deg[b]; });
  const bool pulses = series.blur_rad != nullptr && !series.blur_rad->empty();
  x.blur_rad = pulses ? *series.blur_rad : std::vector<double>(series.frames.size(), opt.blur_rad);
  for (int s = 0; s < 2; ++s) {
    const std::vector<double>& ref = x.ref[s];
    x.top[s] = ref.size();
    for (size_t i = 0; i < ref.size(); ++i)
      if (std::isfinite(ref[i]) && (x.top[s] == ref.size() || ref[i] > ref[x.top[s]])) x.top[s] = i;
  }
  return x;
}

// Edge e's angle past edge j's, turning the tool on: the images after the one where j faces a
// side show e there after this many degrees (the turn brings smaller flute angles round).
double PeakAfterDeg(const ToolDescription& t, int j, int e) {
  const double d = (t.FluteAngle(j) - t.FluteAngle(e)) * base::kDegPerRad;
  return d - 360.0 * std::floor(d / 360.0);
}

// Half the smaller pitch either side of edge e [deg]: how far its peak may be looked for.
double HalfPitchDeg(const ToolDescription& t, int e) {
  const int n = t.flutes;
  return 0.5 * std::min(PeakAfterDeg(t, (e + 1) % n, e), PeakAfterDeg(t, e, (e + n - 1) % n));
}

// The image (position k in angular order) with the highest extreme in `ref` (one per image)
// within `half_deg` of `want_deg`; order.size() when there is none.
size_t PeakImage(const IndexedImages& x,
                 const std::vector<double>& ref,
                 double want_deg,
                 double half_deg) {
  size_t k_best = x.order.size();
  for (size_t k = 0; k < x.order.size(); ++k) {
    const size_t i = x.order[k];
    if (std::abs(base::WrapDeg(x.angle_deg[i] - want_deg)) > half_deg || !std::isfinite(ref[i]))
      continue;
    if (k_best == x.order.size() || ref[i] > ref[x.order[k_best]]) k_best = k;
  }
  return k_best;
}

// The extreme's offset from image k (in angular order) in `ref` [deg]: a parabola through it
// and its neighbours at their angles (measured ones need not be evenly spaced) places the
// peak between images.
double PeakOffsetDeg(const IndexedImages& x, const std::vector<double>& ref, size_t k) {
  const size_t n = x.order.size(), im = x.order[(k + n - 1) % n], ip = x.order[(k + 1) % n];
  const double a0 = x.angle_deg[x.order[k]];
  const double am = base::WrapDeg(x.angle_deg[im] - a0), ap = base::WrapDeg(x.angle_deg[ip] - a0);
  if (!(am < 0 && ap > 0)) return 0.0;
  const double y0 = ref[x.order[k]], sm = (ref[im] - y0) / am, sp = (ref[ip] - y0) / ap;
  const double c2 = (sp - sm) / (ap - am), c1 = sp - c2 * ap;  // y - y0 = c1 t + c2 t^2
  return std::isfinite(c2) && c2 < 0 ? -c1 / (2 * c2) : 0.0;
}

// The edge's turn in image i when its extreme on `side` lies at `peak_deg`: the edge at the
// side (+y: 90 deg, -y: -90 deg) at the reference height.
double TurnInImage(const IndexedImages& x,
                   const ToolDescription& model,
                   int e,
                   int side,
                   const MeasureOptions& opt,
                   double peak_deg,
                   size_t i) {
  return side * M_PI / 2 - model.EdgeAngle(e, opt.h_ref_mm, 0.0) -
         base::WrapDeg(peak_deg - x.angle_deg[i]) / base::kDegPerRad;
}

// Which edge faces `side` at its highest peak: with unequal pitch the one whose pitches, laid
// out from there, put every flute's predicted peak nearest the peak found near it (seed 000
// example 3's seven flutes); equal pitch: edge 0.
int TopEdge(const IndexedImages& x, const ToolDescription& t, int side) {
  if (t.EqualPitch()) return 0;
  const int n = t.flutes;
  const size_t top = x.top[SideIndex(side)];
  size_t k_top = 0;
  while (x.order[k_top] != top) ++k_top;
  const double top_deg = x.angle_deg[top] + PeakOffsetDeg(x, x.ref[SideIndex(side)], k_top);
  int best_j = 0;
  double best = 1e300;
  for (int j = 0; j < n; ++j) {
    double cost = 0;
    for (int f = 0; f < n; ++f) {
      const int e = ((j - f) % n + n) % n;
      const double want = top_deg + PeakAfterDeg(t, j, e);
      const size_t k = PeakImage(x, x.ref[SideIndex(side)], want, HalfPitchDeg(t, e));
      const double found =
          k < x.order.size() ? x.angle_deg[x.order[k]] + PeakOffsetDeg(x, x.ref[SideIndex(side)], k)
                             : want + HalfPitchDeg(t, e);  // none: as far as it may be
      cost += std::pow(base::WrapDeg(found - want), 2);
    }
    if (cost < best) best = cost, best_j = j;
  }
  return best_j;
}

// An electrode's indexing (seed 000 example 5): the model's extreme +y at the reference height
// as a function of the turn, truncated below half way between its least and greatest value
// (the faces' middles, where the neighbouring corners take over), shifted against the images'
// extremes truncated alike; the best overlap is the turn at angular position 0 [deg], and so
// says which corner peaks where. Why not the peaks alone: an electrode's peaks are broad (its
// corners are a rectangle's, a sine's top) and its pitches repeat after half a turn; the
// whole function fixes the shift to a fraction of an image step. The section looks the same
// after half a turn: with `start_turn_deg` the overlap is taken within a quarter turn of it.
double ShadowFunctionShiftDeg(const IndexedImages& x,
                              const ToolDescription& t,
                              const MeasureOptions& opt) {
  constexpr int kPerDeg = 10;
  constexpr int kSteps = 360 * kPerDeg;
  std::vector<double> model(kSteps);
  for (int i = 0; i < kSteps; ++i) {
    double lo = 0, hi = 0;
    t.ShadowSpan(opt.h_ref_mm, i / (kPerDeg * base::kDegPerRad), &lo, &hi);
    model[static_cast<size_t>(i)] = hi;
  }
  // The level: half way, or the least extreme an image shows if higher (a large electrode's
  // flank leaves the field between its corners: those images count as at the level).
  const auto [least, most] = std::minmax_element(model.begin(), model.end());
  double level = (*least + *most) / 2, least_seen = 1e300;
  for (const double y : x.ref[0])
    if (std::isfinite(y)) least_seen = std::min(least_seen, y);
  if (least_seen < 1e300) level = std::max(level, least_seen);
  for (double& v : model) v = std::max(v, level);
  std::vector<std::pair<int, double>> seen;  // (angle in steps, truncated extreme)
  for (size_t i = 0; i < x.ref[0].size(); ++i)
    seen.emplace_back(static_cast<int>(std::lround(x.angle_deg[i] * kPerDeg)) % kSteps,
                      std::isfinite(x.ref[0][i]) ? std::max(x.ref[0][i], level) : level);
  std::vector<double> cost(kSteps, 0.0);
  for (int s = 0; s < kSteps; ++s)
    for (const auto& [a, y] : seen) {
      const double d = y - model[static_cast<size_t>((a + s) % kSteps)];
      cost[static_cast<size_t>(s)] += d * d;
    }
  int best = -1;
  for (int s = 0; s < kSteps; ++s) {
    if (opt.start_turn_deg &&
        std::abs(base::WrapDeg(s / double(kPerDeg) - *opt.start_turn_deg)) > 90)
      continue;
    if (best < 0 || cost[static_cast<size_t>(s)] < cost[static_cast<size_t>(best)]) best = s;
  }
  // A parabola through the least cost and its neighbours.
  const double cm = cost[static_cast<size_t>((best + kSteps - 1) % kSteps)],
               c0 = cost[static_cast<size_t>(best)],
               cp = cost[static_cast<size_t>((best + 1) % kSteps)];
  const double curve = cm - 2 * c0 + cp;
  const double frac = curve > 0 ? 0.5 * (cm - cp) / curve : 0.0;
  return (best + frac) / kPerDeg;
}

// The edge at the +y side's highest peak when the turn at position 0 is `shift_deg`: the one
// whose own peak (edge e faces +y at 90 - angle_e - shift) lies nearest it.
int EdgeAtTopPeak(const IndexedImages& x, const ToolDescription& t, double shift_deg) {
  const double top_deg = x.angle_deg[x.top[0]];
  int best = 0;
  double nearest = 1e300;
  for (int e = 0; e < t.flutes; ++e) {
    const double d =
        std::abs(base::WrapDeg(top_deg - (90.0 - t.FluteAngle(e) * base::kDegPerRad - shift_deg)));
    if (d < nearest) nearest = d, best = e;
  }
  return best;
}

// Edge e on `side`, its extreme near `want_deg`: the principal image, the peak's offset
// between images and the view measured.
FluteView PrincipalView(const IndexedImages& x,
                        const ToolDescription& model,
                        int e,
                        int side,
                        double want_deg,
                        const MeasureOptions& opt,
                        double pitch_deg) {
  const size_t k = PeakImage(x, x.ref[SideIndex(side)], want_deg, HalfPitchDeg(model, e));
  if (k == x.order.size())
    Fail("no image near edge " + std::to_string(e + 1) + " on the " + (side > 0 ? "+y" : "-y") +
         " flank");
  const double peak_deg = x.angle_deg[x.order[k]] + PeakOffsetDeg(x, x.ref[SideIndex(side)], k);
  const std::string name =
      "edge " + std::to_string(e + 1) + " on the " + (side > 0 ? "+y" : "-y") + " flank";
  // The principal image, else its neighbours nearest the peak first: a coolant drop or chip
  // on the edge in one image (the virtual camera's 1.5 a frame put a D1 drill's principal
  // image 13 of 412 points on the model) leaves the next image, 1/positions of a turn on,
  // showing the same edge. Only when none of the three fits is the edge refused (the first
  // image's reason).
  const size_t n = x.order.size();
  const double before = base::WrapDeg(peak_deg - x.angle_deg[x.order[(k + n - 1) % n]]);
  const double after = base::WrapDeg(x.angle_deg[x.order[(k + 1) % n]] - peak_deg);
  const std::array<size_t, 3> tries = {k, before <= after ? (k + n - 1) % n : (k + 1) % n,
                                       before <= after ? (k + 1) % n : (k + n - 1) % n};
  std::string first_reason;
  for (const size_t kk : tries) {
    const size_t i0 = x.order[kk];
    const double turn0 = TurnInImage(x, model, e, side, opt, peak_deg, i0);
    try {
      FluteView v = MeasureView(x.outlines[SideIndex(side)][i0], model, e, turn0, side,
                                InImage(x, i0, opt), pitch_deg, name);
      v.frame = static_cast<int>(i0);
      v.angle_deg = peak_deg;
      v.principal = kk == k;
      return v;
    } catch (const ToolError& refused) {
      if (first_reason.empty()) first_reason = refused.what();
    }
  }
  throw ToolError(first_reason);
}

// A helical flute's end faces the side in another image than its reference height does: the
// helix turns it h_ref tan(helix) / r on. A worn corner shows only there: in the principal
// image the end's silhouette is the tooth's back, whose corner the wear has not reached (the
// outside renderer's D12, 45 deg helix, corner worn to R 0.05: no finding). That image's
// corner findings join the view's; its fit gives nothing else. Pointed and straight tools
// show their end in the principal image.
void AddEndCornerFindings(const IndexedImages& x,
                          const ToolDescription& model,
                          int e,
                          const MeasureOptions& opt,
                          double pitch_deg,
                          FluteView* v) {
  if (model.point_angle_deg > 0 || model.helix_deg < 5.0) return;
  const double end_deg = v->angle_deg + opt.h_ref_mm * model.HelixTurnPerMm() * base::kDegPerRad;
  size_t nearest = x.order.front();
  for (const size_t i : x.order)
    if (std::abs(base::WrapDeg(x.angle_deg[i] - end_deg)) <
        std::abs(base::WrapDeg(x.angle_deg[nearest] - end_deg)))
      nearest = i;
  if (static_cast<int>(nearest) == v->frame) return;
  const double turn0 = TurnInImage(x, model, e, v->side, opt, v->angle_deg, nearest);
  try {
    const FluteView end =
        MeasureView(x.outlines[SideIndex(v->side)][nearest], model, e, turn0, v->side,
                    InImage(x, nearest, opt), pitch_deg, "the end", true);
    // Its findings at the corner: the corner's own, or wear long enough to be a finding on
    // the flank or the end alone that reaches the corner (a corner worn to R 0.06 leaves 0.04
    // mm of the flank 4 um in).
    const double reach_mm = kCornerReachMm + kEndRowMm + 0.6 * model.EndHeight();
    for (Finding fd : end.findings) {
      const double near_end = fd.h_mm - fd.length_mm / 2 - end.tip_h_mm;
      const double near_side = end.radius_mm - (std::abs(fd.y_mm) + fd.length_mm / 2);
      if (!fd.corner && (fd.buildup || (fd.on_end ? near_side : near_end) > reach_mm)) continue;
      fd.corner = fd.on_end = true;
      if (fd.y_mm == 0) fd.y_mm = v->side * end.radius_mm;
      // One place, one finding: a rounded corner's chip the principal image showed already.
      const auto same_place = [&](const Finding& seen) {
        return seen.on_end && std::hypot(seen.y_mm - fd.y_mm, seen.h_mm - fd.h_mm) <
                                  (seen.length_mm + fd.length_mm) / 2;
      };
      if (std::none_of(v->findings.begin(), v->findings.end(), same_place))
        v->findings.push_back(fd);
    }
    v->end_frame = static_cast<int>(nearest);
  } catch (const ToolError&) {
    v->end_frame = -1;  // a drop there: the corner not examined (said in the view)
  }
}

// Flute f (further round from the highest peak) faces a side after edge j0: (j0 - f) mod n.
int EdgeOfFlute(int j0, int f, int n) { return ((j0 - f) % n + n) % n; }

// The flute's figures from its views: with both, their means.
FluteMeasurement FromViews(FluteView plus, std::optional<FluteView> minus, int edge) {
  FluteMeasurement fm;
  fm.edge = edge;
  fm.plus = std::move(plus);
  fm.minus = std::move(minus);
  fm.radius_mm = fm.plus.radius_mm, fm.tip_h_mm = fm.plus.tip_h_mm;
  fm.radius_u_mm = fm.plus.radius_u_mm, fm.tip_u_mm = fm.plus.tip_u_mm;
  fm.angle_deg = fm.plus.angle_deg;
  if (fm.minus) {
    const double apart = std::abs(fm.plus.tip_h_mm - fm.minus->tip_h_mm);
    if (apart > kFlankTipsAgreeMm + 3 * std::hypot(fm.plus.tip_u_mm, fm.minus->tip_u_mm))
      Fail("edge " + std::to_string(edge + 1) + ": its +y and -y views put its tip " +
           std::to_string(std::lround(apart * 1e3)) +
           " um apart (a flank slid along its helix?): not measured");
    fm.radius_mm = (fm.plus.radius_mm + fm.minus->radius_mm) / 2;
    fm.tip_h_mm = (fm.plus.tip_h_mm + fm.minus->tip_h_mm) / 2;
    fm.radius_u_mm = std::hypot(fm.plus.radius_u_mm, fm.minus->radius_u_mm) / 2;
    fm.tip_u_mm = std::hypot(fm.plus.tip_u_mm, fm.minus->tip_u_mm) / 2;
  }
  return fm;
}

// One series: each flute's edge (edges[f], flute f round from the +y side's highest peak)
// against `model`, on +y and, with the axis in view, on -y half a turn on.
std::vector<FluteMeasurement> MeasureFlutes(const IndexedImages& x,
                                            const ToolDescription& model,
                                            const std::vector<int>& edges,
                                            const MeasureOptions& opt,
                                            double pitch_deg) {
  std::vector<FluteMeasurement> flutes;
  for (const int e : edges) {
    const double want = x.angle_deg[x.top[0]] + PeakAfterDeg(model, edges[0], e);
    FluteView plus = PrincipalView(x, model, e, 1, want, opt, pitch_deg);
    AddEndCornerFindings(x, model, e, opt, pitch_deg, &plus);
    std::optional<FluteView> minus;
    if (x.both) {
      minus = PrincipalView(x, model, e, -1, plus.angle_deg + 180.0, opt, pitch_deg);
      AddEndCornerFindings(x, model, e, opt, pitch_deg, &*minus);
    }
    flutes.push_back(FromViews(std::move(plus), std::move(minus), e));
  }
  return flutes;
}

// The views on `side` of edges[f], flute f round from that side's highest peak.
std::vector<FluteView> SideViews(const IndexedImages& x,
                                 const ToolDescription& model,
                                 int side,
                                 const std::vector<int>& edges,
                                 const MeasureOptions& opt,
                                 double pitch_deg) {
  std::vector<FluteView> views;
  views.reserve(edges.size());
  const double top_deg = x.angle_deg[x.top[SideIndex(side)]];
  for (const int e : edges)
    views.push_back(PrincipalView(x, model, e, side, top_deg + PeakAfterDeg(model, edges[0], e),
                                  opt, pitch_deg));
  return views;
}

std::vector<int> EdgesFrom(int j0, int n) {
  std::vector<int> edges(static_cast<size_t>(n));
  for (int f = 0; f < n; ++f) edges[static_cast<size_t>(f)] = EdgeOfFlute(j0, f, n);
  return edges;
}

// Which of the reference's edges is at the highest peak: the turn of the edges' order that
// fits radii and tips best, among those the pitches allow (equal pitch: all).
int FirstEdge(const std::vector<FluteMeasurement>& flutes,
              const ToolDescription& nominal,
              int j_pitch) {
  const int n = nominal.flutes;
  int j0 = j_pitch;
  double best = 1e300;
  for (int j = 0; j < n; ++j) {
    bool same_pitches = true;  // the pitches from j as from j_pitch (a symmetric pattern)
    for (int f = 0; f < n; ++f)
      same_pitches = same_pitches &&
                     std::abs(PeakAfterDeg(nominal, j, EdgeOfFlute(j, f, n)) -
                              PeakAfterDeg(nominal, j_pitch, EdgeOfFlute(j_pitch, f, n))) < 0.5;
    if (!same_pitches) continue;
    double cost = 0;
    for (int f = 0; f < n; ++f) {
      const int e = EdgeOfFlute(j, f, n);
      const double dr = flutes[static_cast<size_t>(f)].radius_mm -
                        (nominal.Radius() + nominal.edges[static_cast<size_t>(e)].radial_offset_mm);
      const double dt = flutes[static_cast<size_t>(f)].tip_h_mm - nominal.TipH(e);
      cost += dr * dr + dt * dt;
    }
    if (cost < best) best = cost, j0 = j;
  }
  return j0;
}

// The tool from its flutes: the largest radius, the lowest tip, runout, eccentricity, the
// axis' offset (both flanks) and the worst finding.
void Summarise(ToolMeasurement* t) {
  t->radius_mm = 0;
  double smallest = 1e300, axis = 0;
  t->tip_h_mm = 1e300;
  for (const auto& f : t->flutes) {
    t->radius_mm = std::max(t->radius_mm, f.radius_mm);
    smallest = std::min(smallest, f.radius_mm);
    t->tip_h_mm = std::min(t->tip_h_mm, f.tip_h_mm);
    if (f.minus) axis += (f.plus.radius_mm - f.minus->radius_mm) / 2;
    for (const Finding* d : f.Findings())
      t->worst_finding_mm = std::max(t->worst_finding_mm, d->max_mm);
  }
  t->runout_mm = t->radius_mm - smallest;
  t->both_flanks = !t->flutes.empty() && t->flutes.front().minus.has_value();
  if (t->both_flanks) t->axis_offset_mm = axis / static_cast<double>(t->flutes.size());
  Eccentricity(t);
}

}  // namespace

MeasureOptions ForTool(const ToolDescription& tool) {
  MeasureOptions o;
  if (tool.reference_height_mm > 0) {
    o.h_ref_mm = tool.reference_height_mm;
    return o;
  }
  // Near the end, so that the helix has turned the edge little between the reference height
  // and the end the fit leans on: within an eighth of the lead (a D1 drill's 30 deg helix
  // turns an edge face-on 1.4 mm up, so 1.5 mm indexes a web), yet 0.4 mm clear of the
  // end's shape (a ball nose's, a drill's point).
  const double lead_mm =
      tool.helix_deg > 0 ? 2 * M_PI * tool.Radius() / std::tan(tool.helix_deg / base::kDegPerRad)
                         : 1e300;
  o.h_ref_mm = std::max(tool.EndHeight() + 0.4, std::min(MeasureOptions::kDefaultReferenceHeightMm,
                                                         tool.EndHeight() + lead_mm / 8));
  return o;
}

Vec2 ToolFromImage(const Vec2& px, const ToolCameraModel& c) {
  return c.ToolFromPixel(c.Undistort(px));
}

double ShadowLevel(const std::vector<std::uint8_t>& pixels) {
  // The whole frame as one row: the level only counts the greys.
  return geometry::HalfLevel({pixels.data(), static_cast<int>(pixels.size()), 1});
}

namespace {

// Each row's first rise through `level` going away from the spindle axis (column
// `axis_u(v)`) on one side, only where the row starts in the tool's shadow at the axis: a drop
// in the light makes a crossing too, and a row below the tool starts in the light. The -y
// side's rows are read mirrored (a copy, right to left), so both flanks use one detector.
template <class AxisColumn>
std::vector<Vec2> FlankFromAxis(const geometry::GreyView& g,
                                double level,
                                int side,
                                AxisColumn axis_u) {
  std::vector<Vec2> flank;
  if (side > 0 && axis_u(0) < 0.5 && axis_u(g.height - 1) < 0.5) {
    // The axis left of the image (a tool wider than the field): every row from column 0, in
    // one pass (per-row calls cost a large tool's measurement a third more time).
    const geometry::Points2 rows = geometry::RowCrossings(g, level);
    for (Eigen::Index i = 0; i < rows.cols(); ++i)
      if (g.At(0, static_cast<int>(rows(1, i))) < level) flank.emplace_back(rows.col(i));
    return flank;
  }
  std::vector<std::uint8_t> row;
  for (int v = 0; v < g.height; ++v) {
    const int u0 = std::clamp(static_cast<int>(std::lround(axis_u(v))), 0, g.width - 1);
    const int n = side > 0 ? g.width - u0 : u0 + 1;
    if (n < 8 || g.At(u0, v) >= level) continue;
    geometry::GreyView line = g.Window(u0, v, n, 1);  // +y: the row as it is
    if (side < 0) {                                   // -y: the row mirrored, a copy
      row.resize(static_cast<size_t>(n));
      for (int i = 0; i < n; ++i)
        row[static_cast<size_t>(i)] = static_cast<std::uint8_t>(g.At(u0 - i, v));
      line = {row.data(), n, 1};
    }
    const geometry::Points2 c = geometry::RowCrossings(line, level);
    if (c.cols() == 1) flank.emplace_back(side > 0 ? u0 + c(0, 0) : u0 - c(0, 0), v);
  }
  return flank;
}

}  // namespace

Outline ExtractOutline(const std::vector<std::uint8_t>& pixels, const ToolCameraModel& c) {
  if (pixels.size() != static_cast<size_t>(c.width_px) * static_cast<size_t>(c.height_px))
    Bad("a frame's size is not the camera's");
  const geometry::GreyView g{pixels.data(), c.width_px, c.height_px};
  const double level = ShadowLevel(pixels);
  // The spindle axis in the image (the roll leans it): its column at each row.
  const Vec2 a0 = c.PixelFromTool({0, 0}), a1 = c.PixelFromTool({0, 1});
  const double du_dv = (a1.x() - a0.x()) / (a1.y() - a0.y());
  const auto axis_u = [&](int v) { return a0.x() + (v - a0.y()) * du_dv; };
  Outline o;
  for (const Vec2& p : FlankFromAxis(g, level, 1, axis_u)) o.side.push_back(ToolFromImage(p, c));
  if (axis_u(0) >= 0 || axis_u(c.height_px - 1) >= 0)  // the axis in view: the -y flank too
    for (const Vec2& p : FlankFromAxis(g, level, -1, axis_u))
      o.side_neg.push_back(ToolFromImage(p, c));
  // The end: each column's first rise out of the shadow from the top. Columns light at the
  // top apart (Outline::bottom_open), when the shadow above the crossing is at least kEndRunMm
  // tall: where a helix turns the flank in above the end, the columns under the end's
  // outermost part are light at the top (a helical tool's worn corner was unseen).
  const geometry::Points2 cols = geometry::ColumnCrossings(g, level);
  const int min_run_px = static_cast<int>(std::ceil(kEndRunMm / c.mm_per_px));
  for (Eigen::Index i = 0; i < cols.cols(); ++i) {
    const int u = static_cast<int>(cols(0, i));
    int run = 0;
    if (g.At(u, 0) >= level)
      for (int v = static_cast<int>(cols(1, i)); v >= 0 && g.At(u, v) < level; --v) ++run;
    if (g.At(u, 0) < level)
      o.bottom.push_back(ToolFromImage(cols.col(i), c));
    else if (run >= min_run_px)
      o.bottom_open.push_back(ToolFromImage(cols.col(i), c));
  }
  return o;
}

namespace {

// The smallest angle between neighbouring flutes [deg].
double SmallestPitchDeg(const ToolDescription& t) {
  double pitch = 360.0;
  for (int k = 0; k < t.flutes; ++k)
    pitch = std::min(pitch, PeakAfterDeg(t, (k + 1) % t.flutes, k));
  return t.flutes > 1 ? pitch : 360.0;
}

// Where the highest peak in `ref` (an extreme per image) lies within `half_deg` of
// `near_deg` [deg], between images; NaN: none.
double PeakDeg(const IndexedImages& x,
               const std::vector<double>& ref,
               double near_deg,
               double half_deg) {
  const size_t k = PeakImage(x, ref, near_deg, half_deg);
  return k == x.order.size() ? std::nan("") : x.angle_deg[x.order[k]] + PeakOffsetDeg(x, ref, k);
}

// The helix' winding in the images against what the files say (`helix_hand`, and the series'
// `spindle.direction` through the positions): an edge facing +y at the reference height faces
// it at h + dh a turn of -dh k later (k: HelixTurnPerMm). A peak that moves the other way by at
// least half that is a hand or a direction stated wrong, which the flank's fit does not show
// (on the outside corpus a wrong hand left radius and length within 0.3 um) but sends the
// end's corner examination to the wrong image: refused as bad input. Under 2 deg of expected
// move, or no second height in view, not checked.
void CheckHelixWinding(const IndexedImages& x, const ToolDescription& tool, MeasureOptions opt) {
  if (tool.helix_deg < 5.0 || tool.electrode || tool.pin || tool.stylus) return;
  const double k = tool.HelixTurnPerMm(), h0 = opt.h_ref_mm;
  const double peak0 = PeakDeg(x, x.ref[0], 0.0, 180.0);  // anywhere
  const double half_deg = 0.5 * SmallestPitchDeg(tool);
  // a rise that turns the edge ~14 deg at most: a small drill's helix turns it 40 deg in 0.6 mm
  const double rise = std::min(kWindingRiseMm, 0.25 / std::abs(k));
  for (const double dh : {rise, -rise}) {
    if (h0 + dh < tool.EndHeight() + opt.band_mm || h0 + dh > tool.flute_length_mm - opt.band_mm)
      continue;
    const double expected_deg = -dh * k * base::kDegPerRad;
    if (std::abs(expected_deg) < 2.0) return;
    opt.h_ref_mm = h0 + dh;
    std::vector<double> ref;
    for (const Outline& o : x.outlines[0]) ref.push_back(ReferenceY(o.side, opt));
    const double moved_deg = base::WrapDeg(PeakDeg(x, ref, peak0, half_deg) - peak0);
    if (!std::isfinite(moved_deg)) continue;  // the second height out of view
    if (moved_deg * expected_deg < 0 && std::abs(moved_deg) >= 0.5 * std::abs(expected_deg)) {
      std::ostringstream msg;
      msg << std::fixed << std::setprecision(1) << "the flutes wind the other way in the images "
          << "than the tool's helix_hand (" << (tool.left_hand_helix ? "left" : "right")
          << ") and the series' spindle.direction say: the +y flank's peak moves " << moved_deg
          << " deg from h " << h0 << " to " << h0 + dh << " mm, " << expected_deg << " expected";
      Bad(msg.str());
    }
    return;
  }
}

// A series that can index every flute: 3 images a flute, positions within the plan, no gap in
// the turn wider than half the smallest pitch (else a flute's peak may fall where no image
// is, and the nearest image's flank is measured as the edge's); and a reference height above
// the end's shape, within the flutes.
void CheckSeries(const ToolSeries& s, const ToolDescription& tool, const MeasureOptions& opt) {
  const int flutes = tool.flutes;
  if (s.frames.size() != s.positions.size() || s.position_count < 3 * flutes ||
      s.frames.size() < 3 * static_cast<size_t>(flutes))
    Bad("at least 3 images per flute, each with its angular position, are needed");
  if (s.angle_deg != nullptr && !s.angle_deg->empty() && s.angle_deg->size() != s.frames.size())
    Bad("a measured angle for every image, or none");
  if (s.blur_rad != nullptr && !s.blur_rad->empty() && s.blur_rad->size() != s.frames.size())
    Bad("a pulse for every image, or none");
  for (const int p : s.positions)
    if (p < 0 || p >= s.position_count)
      Bad("an image's angular position is outside 0.." + std::to_string(s.position_count - 1));
  std::vector<double> at = SeriesAnglesDeg(s);
  for (double& a : at) {
    if (!std::isfinite(a)) Bad("an image's measured angle is not a number");
    a -= 360.0 * std::floor(a / 360.0);
  }
  std::sort(at.begin(), at.end());
  double gap_deg = at.front() + 360.0 - at.back();
  for (size_t i = 1; i < at.size(); ++i) gap_deg = std::max(gap_deg, at[i] - at[i - 1]);
  if (gap_deg > SmallestPitchDeg(tool) / 2)
    Fail("the images leave " + std::to_string(std::lround(gap_deg)) +
         " deg of the turn unseen, over half the smallest pitch (" +
         std::to_string(std::lround(SmallestPitchDeg(tool))) + " deg): a flute may not be seen");
  if (!(opt.h_ref_mm > tool.EndHeight() && opt.h_ref_mm < tool.flute_length_mm))
    Bad("the reference height " + std::to_string(opt.h_ref_mm) +
        " mm must lie above the end's shape (" + std::to_string(tool.EndHeight()) +
        " mm) and below the flute length");
}

bool IsReference(const ToolDescription& t) {
  return std::any_of(t.edges.begin(), t.edges.end(),
                     [](const CuttingEdge& e) { return e.Measured(); });
}

// Which -y flute pairs with +y flute 0 (equal pitch; the series' starts are unknown): the
// turn of the order whose tips, and radii about each side's mean, agree best.
int MatchOtherSide(const std::vector<FluteView>& plus, const std::vector<FluteView>& minus) {
  const size_t n = plus.size();
  double mean_p = 0, mean_m = 0;
  for (size_t f = 0; f < n; ++f) mean_p += plus[f].radius_mm, mean_m += minus[f].radius_mm;
  mean_p /= static_cast<double>(n), mean_m /= static_cast<double>(n);
  size_t best_s = 0;
  double best = 1e300;
  for (size_t s = 0; s < n; ++s) {
    double cost = 0;
    for (size_t f = 0; f < n; ++f) {
      const FluteView& m = minus[(f + s) % n];
      cost += std::pow(plus[f].tip_h_mm - m.tip_h_mm, 2) +
              std::pow((plus[f].radius_mm - mean_p) - (m.radius_mm - mean_m), 2);
    }
    if (cost < best) best = cost, best_s = s;
  }
  return static_cast<int>(best_s);
}

// An electrode's corners' wear against the nominal (or the stored reference) and the worst.
void CornerWear(const ToolDescription& nominal, ToolMeasurement* t) {
  for (FluteMeasurement& f : t->flutes) {
    const auto e = static_cast<size_t>(f.edge);
    f.radial_wear_mm = nominal.Radius() + nominal.edges[e].radial_offset_mm - f.radius_mm;
    f.axial_wear_mm = f.tip_h_mm - nominal.TipH(f.edge);
    t->worst_wear_mm = std::max({t->worst_wear_mm, f.radial_wear_mm, f.axial_wear_mm});
  }
}

}  // namespace

ToolMeasurement MeasureTool(const std::vector<std::vector<std::uint8_t>>& frames,
                            const std::vector<int>& positions,
                            int position_count,
                            const ToolDescription& nominal,
                            const ToolCameraModel& camera,
                            const MeasureOptions& opt) {
  return MeasureTool(ToolSeries{frames, positions, position_count, camera}, nominal, opt);
}

ToolMeasurement MeasureTool(const ToolSeries& series,
                            const ToolDescription& nominal,
                            const MeasureOptions& opt) {
  const std::vector<std::vector<std::uint8_t>>& frames = series.frames;
  const ToolCameraModel& camera = series.camera;
  CheckSeries(series, nominal, opt);
  // The images in angular order; the flutes are the maxima of the reference height's extreme.
  const IndexedImages x = IndexImages(series, opt);
  if (x.top[0] == frames.size()) Fail("no image shows the outline at the reference height");
  const int j_pitch = nominal.electrode
                          ? EdgeAtTopPeak(x, nominal, ShadowFunctionShiftDeg(x, nominal, opt))
                          : TopEdge(x, nominal, 1);
  ToolMeasurement t;
  // First against the ground (unworn) tool; against a stored reference each flute again,
  // against its own edge once the order is known (by its radii and tips, unless the chuck
  // named an electrode's corners).
  t.flutes =
      MeasureFlutes(x, Ground(nominal), EdgesFrom(j_pitch, nominal.flutes), opt, camera.pitch_deg);
  CheckHelixWinding(x, nominal, opt);  // once the images show the tool's flutes
  const bool chuck_named = nominal.electrode && opt.start_turn_deg.has_value();
  if (IsReference(nominal))
    t.flutes = MeasureFlutes(
        x, nominal,
        EdgesFrom(chuck_named ? j_pitch : FirstEdge(t.flutes, nominal, j_pitch), nominal.flutes),
        opt, camera.pitch_deg);
  Summarise(&t);
  if (nominal.electrode) {
    CornerWear(nominal, &t);
    t.half_turn_ambiguous = !chuck_named && !IsReference(nominal);
  }
  return t;
}

ToolMeasurement MeasureToolBothSides(const ToolSeries& plus,
                                     const ToolSeries& minus,
                                     const ToolDescription& nominal,
                                     const MeasureOptions& opt) {
  const int n = nominal.flutes;
  const auto count = static_cast<size_t>(n);
  CheckSeries(plus, nominal, opt), CheckSeries(minus, nominal, opt);
  const IndexedImages xp = IndexImages(plus, opt), xm = IndexImages(minus, opt);
  if (xp.top[0] == plus.frames.size()) Bad("the +y series does not show the tool's +y flank");
  if (xm.top[1] == minus.frames.size()) Bad("the -y series does not show the tool's -y flank");
  const ToolDescription ground = Ground(nominal);
  const int jp = TopEdge(xp, nominal, 1);
  std::vector<int> edges_p = EdgesFrom(jp, n), edges_m = EdgesFrom(TopEdge(xm, nominal, -1), n);
  const double pitch_p = plus.camera.pitch_deg, pitch_m = minus.camera.pitch_deg;
  std::vector<FluteView> vp = SideViews(xp, ground, 1, edges_p, opt, pitch_p);
  std::vector<FluteView> vm = SideViews(xm, ground, -1, edges_m, opt, pitch_m);
  // +y flute f's -y flute: the one the pitches name as the same edge, or (equal pitch) the
  // turn of the order that pairs tips and radii best.
  std::vector<size_t> pair(count);
  const int shift = nominal.EqualPitch() ? MatchOtherSide(vp, vm) : 0;
  for (size_t f = 0; f < count; ++f)
    pair[f] = nominal.EqualPitch()
                  ? (f + static_cast<size_t>(shift)) % count
                  : static_cast<size_t>(std::find(edges_m.begin(), edges_m.end(), edges_p[f]) -
                                        edges_m.begin());
  const auto combine = [&] {
    std::vector<FluteMeasurement> flutes;
    for (size_t f = 0; f < count; ++f) flutes.push_back(FromViews(vp[f], vm[pair[f]], edges_p[f]));
    return flutes;
  };
  ToolMeasurement t;
  t.flutes = combine();
  if (IsReference(nominal)) {  // each side again against its own edge of the reference
    edges_p = EdgesFrom(FirstEdge(t.flutes, nominal, jp), n);
    for (size_t f = 0; f < count; ++f) edges_m[pair[f]] = edges_p[f];
    vp = SideViews(xp, nominal, 1, edges_p, opt, pitch_p);
    vm = SideViews(xm, nominal, -1, edges_m, opt, pitch_m);
    t.flutes = combine();
  }
  Summarise(&t);
  return t;
}

std::vector<const Finding*> FluteMeasurement::Findings() const {
  std::vector<const Finding*> all;
  for (const Finding& f : plus.findings) all.push_back(&f);
  if (minus)
    for (const Finding& f : minus->findings) all.push_back(&f);
  return all;
}

ToolDescription ReferenceFrom(const ToolDescription& nominal, const ToolMeasurement& m) {
  ToolDescription ref = Ground(nominal);
  for (const FluteMeasurement& fm : m.flutes) {
    if (fm.edge < 0 || fm.edge >= nominal.flutes) continue;
    CuttingEdge& edge = ref.edges[static_cast<size_t>(fm.edge)];
    edge.radial_offset_mm = fm.radius_mm - nominal.Radius();
    edge.axial_offset_mm = -fm.tip_h_mm;
    edge.profile = fm.plus.profile;
  }
  return ref;
}

}  // namespace mlp::toolcam
