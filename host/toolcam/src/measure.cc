#include "mlp/toolcam/measure.h"

#include "mlp/base/units.h"
#include "mlp/geometry/contour.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include <Eigen/Dense>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw ToolError("tool measurement: " + what); }
[[noreturn]] void Bad(const std::string& what) {
  throw ToolInputError("tool measurement: " + what);
}

// Pixel -> tool frame, undoing the lens' radial distortion (the camera's calibration).
Vec2 ToTool(const Vec2& px, const ToolCameraModel& c) { return c.ToolFromPixel(Undistort(px, c)); }

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

double ReferenceY(const Outline& o, const MeasureOptions& opt) {
  std::vector<double> y;
  for (const Vec2& p : o.side)
    if (std::abs(p.y() - opt.h_ref_mm) < opt.band_mm) y.push_back(p.x());
  return Median(y);
}

// The outline points a flute's fit uses, each with the way "outside the model" points: the
// flank (+y) and the flat end (-h).
struct FitPoint {
  Vec2 p;
  bool side = true;
  bool active = true;
  double residual = 0;  ///< outward from the model [mm]
  FluteMeasurement::PointKind kind = FluteMeasurement::kUsed;
};

// The nominal tool (its edges true) shifted by (dy, dh) and turned: the reference model.
struct Model {
  ToolDescription tool;
  double turn0 = 0;  ///< the principal image's turn before the fitted correction
  bool fit_turn = false;

  double blur = 0;
  double tan_pitch = 0;  ///< the camera's (tool_camera.h): an edge's end seen at its depth

  double Reach(double h, double turn) const {
    const ShadowSpans s = tool.Shadow(h, turn, tan_pitch);
    return s.count > 0 ? s.hi[s.count - 1] : 0.0;
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
  };

  Underside Tabulate(double turn) const {
    Underside u;
    constexpr double kStepMm = 0.00025;
    double running = 0;
    for (double h = -0.05; h <= tool.corner_radius_mm + 0.05; h += kStepMm) {
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
        f.residual = (under.At(f.p.x() - x(0)) + x(1)) - f.p.y();
    }
  }
};

// Least squares over the active points (Gauss-Newton, numeric derivatives: the model's
// silhouette has no closed form once the helix turns the edge with height).
Eigen::Vector3d Fit(const Model& m, std::vector<FitPoint>* pts, Eigen::Vector3d x) {
  const int n_par = m.fit_turn ? 3 : 2;
  for (int it = 0; it < 30; ++it) {
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
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n_par, n_par);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(n_par);
    for (size_t i = 0; i < pts->size(); ++i) {
      if (!(*pts)[i].active) continue;
      const Eigen::VectorXd j = jt.col(static_cast<Eigen::Index>(i));
      a += j * j.transpose();
      b -= j * r0[i];
    }
    const Eigen::VectorXd step = a.ldlt().solve(b);
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
std::vector<Finding> Classify(std::vector<FitPoint>* pts, const MeasureOptions& o) {
  for (FitPoint& f : *pts) f.active = true, f.kind = FluteMeasurement::kUsed;
  std::vector<Finding> findings;
  const Ordered ord = Order(*pts);
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
          (*pts)[(*line)[k]].kind = !finding  ? FluteMeasurement::kContamination
                                    : outside ? FluteMeasurement::kBuildup
                                              : FluteMeasurement::kWear;
        if (!finding) return;
        Finding fd;
        fd.buildup = outside;
        fd.h_mm = (*line == ord.side) ? (from + to) / 2 : 0.0;
        fd.length_mm = length, fd.max_mm = worst, fd.area_mm2 = area;
        findings.push_back(fd);
      });
    }
  }
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
    if (!f.side || f.kind == FluteMeasurement::kContamination) continue;
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

// One flute in its principal image against `model`'s edge `edge` (facing the camera at the
// reference height when the tool has turned turn0).
FluteMeasurement MeasureFlute(const Outline& o,
                              const ToolDescription& model,
                              int edge,
                              double turn0,
                              const MeasureOptions& opt,
                              double pitch_deg) {
  const ToolDescription& nominal = model;
  Model m;
  m.tool = model;
  m.turn0 = turn0;
  m.blur = opt.blur_rad;
  m.tan_pitch = std::tan(pitch_deg / base::kDegPerRad);
  m.fit_turn = nominal.helix_deg >= 5.0;  // a straight flute's turn trades with its radius
  const double r = nominal.Radius(), rc = nominal.corner_radius_mm;
  std::vector<FitPoint> pts;
  for (const Vec2& p : o.side)  // the flank, above the corner's flat part
    if (p.y() > 0.6 * rc && p.y() < nominal.flute_length_mm) pts.push_back({p, true});
  for (const Vec2& p : o.bottom)  // the end and the corner, where the outline is not upright
    if (p.x() < r - 0.1 * rc && p.y() < 0.7 * rc) pts.push_back({p, false});
  if (pts.size() < 20) Fail("too few outline points on a flute's principal image");
  Eigen::Vector3d x = Eigen::Vector3d::Zero();
  FluteMeasurement fm;
  for (int round = 0; round < opt.rounds; ++round) {
    x = Fit(m, &pts, x);
    fm.findings = Classify(&pts, opt);
  }
  const CuttingEdge& e = model.edges[static_cast<size_t>(edge)];
  fm.radius_mm = r + e.radial_offset_mm + x(0);
  fm.tip_h_mm = model.TipH(edge) + x(1);
  double ss = 0;
  for (const FitPoint& f : pts) {
    if (!f.active) {
      ++fm.removed;
      continue;
    }
    ss += f.residual * f.residual;
    ++fm.points;
  }
  fm.rms_mm = fm.points > 0 ? std::sqrt(ss / fm.points) : 0.0;
  for (const FitPoint& f : pts) fm.points_yh.push_back(f.p), fm.point_kind.push_back(f.kind);
  fm.profile = Profile(pts, model, edge);
  // The fitted model's outline: the flank down to the corner, then the underside inwards.
  const double turn = m.turn0 + x(2);
  for (double h = 2.5; h >= 0.3 * rc; h -= 0.01)
    fm.model_yh.emplace_back(m.Flank(h, turn) + x(0), h + x(1));
  const auto under = m.Tabulate(turn);
  for (size_t i = under.h.size(); i-- > 0;)
    if (under.y[i] > 0) fm.model_yh.emplace_back(under.y[i] + x(0), under.h[i] + x(1));
  return fm;
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

// The frames' outlines and reference heights, in angular order; `top` the image whose outline
// reaches farthest at the reference height (a flute's edge nearest the +y extreme).
struct IndexedImages {
  std::vector<Outline> outlines;
  std::vector<double> ref;
  std::vector<size_t> order;
  std::vector<double> angle_deg;
  size_t top = 0;
  double step_deg = 0;
};

IndexedImages IndexImages(const std::vector<std::vector<std::uint8_t>>& frames,
                          const std::vector<int>& positions,
                          int position_count,
                          const ToolCameraModel& camera,
                          const MeasureOptions& opt) {
  IndexedImages x;
  for (const auto& f : frames) {
    x.outlines.push_back(ExtractOutline(f, camera));
    x.ref.push_back(ReferenceY(x.outlines.back(), opt));
  }
  x.order.resize(frames.size());
  for (size_t i = 0; i < x.order.size(); ++i) x.order[i] = i;
  std::sort(x.order.begin(), x.order.end(),
            [&](size_t a, size_t b) { return positions[a] < positions[b]; });
  x.step_deg = 360.0 / position_count;
  for (int p : positions) x.angle_deg.push_back(p * x.step_deg);
  for (size_t i = 0; i < x.ref.size(); ++i)
    if (std::isfinite(x.ref[i]) && (!std::isfinite(x.ref[x.top]) || x.ref[i] > x.ref[x.top]))
      x.top = i;
  if (!std::isfinite(x.ref[x.top])) Fail("no image shows the outline at the reference height");
  return x;
}

// Flute f's principal image: the highest reference height within half a pitch of where the
// flute should be (in order, k); order.size() when there is none.
size_t PrincipalImage(const IndexedImages& x, int f, int n) {
  const double want = x.angle_deg[x.top] + f * 360.0 / n;
  size_t k_best = x.order.size();
  for (size_t k = 0; k < x.order.size(); ++k) {
    double off = std::fmod(x.angle_deg[x.order[k]] - want, 360.0);
    off -= 360.0 * std::round(off / 360.0);
    if (std::abs(off) > 180.0 / n || !std::isfinite(x.ref[x.order[k]])) continue;
    if (k_best == x.order.size() || x.ref[x.order[k]] > x.ref[x.order[k_best]]) k_best = k;
  }
  return k_best;
}

// Each flute measured in its principal image against the ground (unworn) tool; the flutes'
// angular offsets from their principal images [deg] in `offsets_deg`.
std::vector<FluteMeasurement> MeasureFlutes(const IndexedImages& x,
                                            const ToolDescription& nominal,
                                            const MeasureOptions& opt,
                                            double pitch_deg,
                                            std::vector<double>* offsets_deg) {
  const int n = nominal.flutes;
  const ToolDescription ground = Ground(nominal);
  std::vector<FluteMeasurement> flutes;
  for (int f = 0; f < n; ++f) {
    const size_t k_best = PrincipalImage(x, f, n);
    if (k_best == x.order.size()) Fail("no image near flute " + std::to_string(f + 1));
    // The maximum between images: a parabola through the principal image and its neighbours.
    const size_t i0 = x.order[k_best];
    const double ym = x.ref[x.order[(k_best + x.order.size() - 1) % x.order.size()]];
    const double yp = x.ref[x.order[(k_best + 1) % x.order.size()]];
    const double curve = ym - 2 * x.ref[i0] + yp;
    const double offset_deg = curve < 0 ? x.step_deg * (ym - yp) / (2 * curve) : 0.0;
    // The principal image's turn: its flute at +y at the reference height, less the offset.
    const double turn0 =
        M_PI / 2 - ground.EdgeAngle(0, opt.h_ref_mm, 0.0) - offset_deg / base::kDegPerRad;
    FluteMeasurement fm = MeasureFlute(x.outlines[i0], ground, 0, turn0, opt, pitch_deg);
    fm.frame = static_cast<int>(i0);
    fm.angle_deg = x.angle_deg[i0] + offset_deg;
    offsets_deg->push_back(offset_deg);
    flutes.push_back(fm);
  }
  return flutes;
}

// Flute f (one pitch further round from the highest peak) faces the camera one edge earlier:
// edge (j0 - f) mod n; j0 the turn of the order that fits radii and tips best.
int FirstEdge(const std::vector<FluteMeasurement>& flutes, const ToolDescription& nominal) {
  const int n = nominal.flutes;
  int j0 = 0;
  double best = 1e300;
  for (int j = 0; j < n; ++j) {
    double cost = 0;
    for (int f = 0; f < n; ++f) {
      const int e = ((j - f) % n + n) % n;
      const double dr = flutes[static_cast<size_t>(f)].radius_mm -
                        (nominal.Radius() + nominal.edges[static_cast<size_t>(e)].radial_offset_mm);
      const double dt = flutes[static_cast<size_t>(f)].tip_h_mm - nominal.TipH(e);
      cost += dr * dr + dt * dt;
    }
    if (cost < best) best = cost, j0 = j;
  }
  return j0;
}

// With a measured reference tool: each flute measured again against its own edge's reference.
void MeasureAgainstReference(const IndexedImages& x,
                             const ToolDescription& nominal,
                             const MeasureOptions& opt,
                             double pitch_deg,
                             const std::vector<double>& offsets_deg,
                             std::vector<FluteMeasurement>* flutes) {
  const int n = nominal.flutes;
  const int j0 = FirstEdge(*flutes, nominal);
  for (int f = 0; f < n; ++f) {
    FluteMeasurement& fm = (*flutes)[static_cast<size_t>(f)];
    const int e = ((j0 - f) % n + n) % n;
    const double turn0 = M_PI / 2 - nominal.EdgeAngle(e, opt.h_ref_mm, 0.0) -
                         offsets_deg[static_cast<size_t>(f)] / base::kDegPerRad;
    FluteMeasurement again =
        MeasureFlute(x.outlines[static_cast<size_t>(fm.frame)], nominal, e, turn0, opt, pitch_deg);
    again.frame = fm.frame, again.angle_deg = fm.angle_deg, again.edge = e;
    fm = again;
  }
}

// The tool from its flutes: the largest radius, the lowest tip, runout and eccentricity.
void Summarise(ToolMeasurement* t) {
  t->radius_mm = 0;
  double smallest = 1e300;
  t->tip_h_mm = 1e300;
  for (const auto& f : t->flutes) {
    t->radius_mm = std::max(t->radius_mm, f.radius_mm);
    smallest = std::min(smallest, f.radius_mm);
    t->tip_h_mm = std::min(t->tip_h_mm, f.tip_h_mm);
  }
  t->runout_mm = t->radius_mm - smallest;
  Eccentricity(t);
}

}  // namespace

Vec2 Undistort(const Vec2& px, const ToolCameraModel& c) {
  const double cx = (c.width_px - 1) / 2.0, cy = (c.height_px - 1) / 2.0;
  const double corner2 = cx * cx + cy * cy;
  const Vec2 d(px.x() - cx, px.y() - cy);
  return Vec2(cx, cy) + d / (1 + c.distortion_k1 * d.squaredNorm() / corner2);
}

double ShadowLevel(const std::vector<std::uint8_t>& pixels) {
  // The whole frame as one row: the level only counts the greys.
  return geometry::HalfLevel({pixels.data(), static_cast<int>(pixels.size()), 1});
}

Outline ExtractOutline(const std::vector<std::uint8_t>& pixels, const ToolCameraModel& c) {
  if (pixels.size() != static_cast<size_t>(c.width_px) * static_cast<size_t>(c.height_px))
    Bad("a frame's size is not the camera's");
  const geometry::GreyView g{pixels.data(), c.width_px, c.height_px};
  const double level = ShadowLevel(pixels);
  Outline o;
  // Only scan lines that start in the tool's shadow: a drop in the light makes a crossing too.
  const geometry::Points2 rows = geometry::RowCrossings(g, level);
  for (Eigen::Index i = 0; i < rows.cols(); ++i)
    if (g.At(0, static_cast<int>(rows(1, i))) < level) o.side.push_back(ToTool(rows.col(i), c));
  const geometry::Points2 cols = geometry::ColumnCrossings(g, level);
  for (Eigen::Index i = 0; i < cols.cols(); ++i)
    if (g.At(static_cast<int>(cols(0, i)), 0) < level) o.bottom.push_back(ToTool(cols.col(i), c));
  return o;
}

ToolMeasurement MeasureTool(const std::vector<std::vector<std::uint8_t>>& frames,
                            const std::vector<int>& positions,
                            int position_count,
                            const ToolDescription& nominal,
                            const ToolCameraModel& camera,
                            const MeasureOptions& opt) {
  const int n = nominal.flutes;
  if (frames.size() != positions.size() || position_count < 3 * n ||
      frames.size() < 3 * static_cast<size_t>(n))
    Bad("at least 3 images per flute, each with its angular position, are needed");
  // The images in angular order; the flutes are the maxima of the reference height's extreme.
  const IndexedImages x = IndexImages(frames, positions, position_count, camera, opt);
  ToolMeasurement t;
  std::vector<double> offsets_deg;
  t.flutes = MeasureFlutes(x, nominal, opt, camera.pitch_deg, &offsets_deg);
  const bool reference = std::any_of(nominal.edges.begin(), nominal.edges.end(),
                                     [](const CuttingEdge& e) { return e.Measured(); });
  if (reference) MeasureAgainstReference(x, nominal, opt, camera.pitch_deg, offsets_deg, &t.flutes);
  Summarise(&t);
  return t;
}

ToolDescription ReferenceFrom(const ToolDescription& nominal, const ToolMeasurement& m) {
  ToolDescription ref = Ground(nominal);
  const int n = nominal.flutes;
  for (int f = 0; f < static_cast<int>(m.flutes.size()) && f < n; ++f) {
    const FluteMeasurement& fm = m.flutes[static_cast<size_t>(f)];
    const int e = fm.edge >= 0 ? fm.edge : (n - f) % n;
    CuttingEdge& edge = ref.edges[static_cast<size_t>(e)];
    edge.radial_offset_mm = fm.radius_mm - nominal.Radius();
    edge.axial_offset_mm = -fm.tip_h_mm;
    edge.profile = fm.profile;
  }
  return ref;
}

}  // namespace mlp::toolcam
