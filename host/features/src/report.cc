#include "mlp/features/report.h"

#include "mlp/base/units.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "svg_text.h"

namespace mlp::features {
namespace {

constexpr double kCentreX = 240, kCentreY = 250, kBaseRadiusPx = 150;
// The largest deviation (or half the tolerance band) is drawn this many pixels off the circle.
constexpr double kMagnifiedPx = 60;

std::string Num(double v, int digits) {
  char b[48];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

// Diverging blue - white - red for t in [-1, 1].
std::string Colour(double t) {
  t = std::clamp(t, -1.0, 1.0);
  const int lo = static_cast<int>(255 * (1 - std::abs(t)));
  char b[16];
  if (t < 0)
    std::snprintf(b, sizeof b, "#%02x%02xff", lo, lo);
  else
    std::snprintf(b, sizeof b, "#ff%02x%02x", lo, lo);
  return b;
}

std::string VerdictColour(const std::string& v) {
  if (v == "in tolerance") return "#1a7f37";
  if (v == "out of tolerance") return "#b35900";
  return "#c00000";
}

void Circle(std::ostringstream& s, double r, const std::string& style) {
  s << "<circle cx='" << kCentreX << "' cy='" << kCentreY << "' r='" << Num(r, 2) << "' " << style
    << "/>\n";
}

// The polar plot: the tolerance band round the nominal, the nominal, the fitted circle, and
// each degree's deviation magnified by k [px/mm], coloured by its sign.
void DeviationPlot(const BoreReport& r, double worst, double k, std::ostringstream& s) {
  const auto& dev = r.bore.deviation_by_degree_mm;
  const double fitted_r = r.bore.diameter_mm / 2;
  // Tolerance band around the nominal (radius = nominal / 2 + tolerance / 2 on either side).
  const double nominal_px = kBaseRadiusPx + k * (r.nominal_mm / 2 - fitted_r);
  Circle(s, nominal_px + k * r.upper_tol_mm / 2, "fill='none' stroke='#8fd19e' stroke-width='1.5'");
  Circle(s, nominal_px - k * r.lower_tol_mm / 2, "fill='none' stroke='#8fd19e' stroke-width='1.5'");
  Circle(s, nominal_px, "fill='none' stroke='#555' stroke-dasharray='6 4'");
  Circle(s, kBaseRadiusPx, "fill='none' stroke='black' stroke-width='1.2'");
  for (size_t b = 0; b < dev.size(); ++b) {
    if (!std::isfinite(dev[b])) continue;
    const double a = (static_cast<double>(b) + 0.5) / base::kDegPerRad;
    const double rr = kBaseRadiusPx + k * dev[b];
    // Screen y points down: machine +Y is up.
    s << "<circle cx='" << Num(kCentreX + rr * std::cos(a), 1) << "' cy='"
      << Num(kCentreY - rr * std::sin(a), 1) << "' r='2.2' fill='"
      << Colour(worst > 0 ? dev[b] / worst : 0) << "' stroke='#333' stroke-width='0.3'/>\n";
  }
  s << "<text x='" << kCentreX << "' y='" << kCentreY + 5
    << "' text-anchor='middle' font-size='12' fill='#555'>+X at 3 o'clock</text>\n";
}

// The text column: verdict, size, fits, coverage, the plot's scale and the decision.
void ReportText(const BoreReport& r, double worst, double k, std::ostringstream& s) {
  const auto& dev = r.bore.deviation_by_degree_mm;
  const double fitted_r = r.bore.diameter_mm / 2;
  const double y0 = 40, dy = 24;
  int line = 0;
  const auto text = [&](const std::string& t, int size, const std::string& colour) {
    s << "<text x='470' y='" << Num(y0 + dy * line++, 0) << "' font-size='" << size << "' fill='"
      << colour << "'>" << SvgText(t) << "</text>\n";
  };
  text(r.title, 16, "black");
  text(r.verdict, 22, VerdictColour(r.verdict));
  text("size " + Num(r.size_mm, 4) + " mm (nominal " + Num(r.nominal_mm, 3) + " +" +
           Num(r.upper_tol_mm, 3) + "/-" + Num(r.lower_tol_mm, 3) + ")",
       13, "black");
  text("error " + Num(r.error_mm * 1e3, 1) + " um", 13, "black");
  text("least squares D " + Num(r.bore.diameter_mm, 4) + " mm", 13, "black");
  if (r.bore.functional_diameter_mm > 0)
    text(std::string(r.boss ? "min circumscribed D " : "max inscribed D ") +
             Num(r.bore.functional_diameter_mm, 4) + " mm",
         13, "black");
  text("centre X " + Num(r.bore.top_centre_mcs.x(), 4) + "  Y " + Num(r.bore.top_centre_mcs.y(), 4),
       13, "black");
  int covered = 0;
  for (double d : dev) covered += std::isfinite(d) ? 1 : 0;
  text(std::to_string(r.bore.points) + " points, RMS " + Num(r.bore.rms_mm * 1e3, 2) + " um", 13,
       "black");
  text(std::to_string(covered) + " deg of the wall seen, largest gap " +
           Num(360.0 - r.bore.arc_span_deg, 0) + " deg",
       13, "black");
  text("deviation x" + Num(k / (kBaseRadiusPx / fitted_r), 0) + " (max " + Num(worst * 1e3, 1) +
           " um)",
       13, "#555");
  text("black: fitted  dashed: nominal  green: tolerance", 12, "#555");
  text("blue: inside  red: outside the fitted circle", 12, "#555");
  // The decision may be long: break it after its first colon.
  const size_t colon = r.decision.find(": ");
  if (colon != std::string::npos && r.decision.size() > 48) {
    text(r.decision.substr(0, colon + 1), 12, "black");
    text("  " + r.decision.substr(colon + 2), 12, "black");
  } else {
    text(r.decision, 12, "black");
  }
  text(r.time_utc, 11, "#777");
}

}  // namespace

std::string BoreReportSvg(const BoreReport& r) {
  double worst = 0;
  for (double d : r.bore.deviation_by_degree_mm)
    if (std::isfinite(d)) worst = std::max(worst, std::abs(d));
  const double fitted_r = r.bore.diameter_mm / 2;
  const double band = 0.5 * (r.upper_tol_mm + r.lower_tol_mm);
  // Pixels per mm of deviation: the worst deviation, the tolerance band and the nominal's
  // offset all fit the drawing.
  const double reach = std::max({worst, band, std::abs(r.nominal_mm / 2 - fitted_r), 1e-4});
  const double k = kMagnifiedPx / reach;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='900' height='500' "
       "font-family='sans-serif'>\n"
    << "<rect width='900' height='500' fill='white'/>\n";
  DeviationPlot(r, worst, k, s);
  ReportText(r, worst, k, s);
  s << "</svg>\n";
  return s.str();
}

namespace {

constexpr int kPanelPx = 200, kMaxPanelPoints = 2500;

// Two directions across `normal`: machine X projected first, so a level face is drawn as
// seen from above with X to the right.
void PlaneAxes(const geometry::Vec3& normal, geometry::Vec3* u, geometry::Vec3* v) {
  const geometry::Vec3 x = geometry::Vec3::UnitX() - normal.dot(geometry::Vec3::UnitX()) * normal;
  *u = x.norm() > 0.1 ? geometry::Vec3(x.normalized()) : geometry::Vec3(normal.unitOrthogonal());
  *v = normal.cross(*u);
}

// The 99th percentile of |deviation| over every panel (at least 0.1 um).
double ColourScale(const std::vector<DeviationPanel>& panels) {
  std::vector<double> all;
  for (const auto& p : panels)
    for (double d : p.deviation_mm) all.push_back(std::abs(d));
  if (all.empty()) return 1e-4;
  const auto k = static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(all.size() - 1));
  std::nth_element(all.begin(), all.begin() + k, all.end());
  return std::max(all[static_cast<size_t>(k)], 1e-4);
}

void Panel(std::ostringstream& s, const DeviationPanel& p, double x0, double y0, double scale) {
  s << "<rect x='" << x0 << "' y='" << y0 << "' width='" << kPanelPx << "' height='" << kPanelPx
    << "' fill='#f4f4f4' stroke='#999'/>\n"
    << "<text x='" << x0 << "' y='" << y0 - 5 << "' font-size='12'>" << SvgText(p.title)
    << "</text>\n";
  if (p.xy_mm.empty()) return;
  double lo_x = 1e300, hi_x = -1e300, lo_y = 1e300, hi_y = -1e300;
  for (const auto& q : p.xy_mm)
    lo_x = std::min(lo_x, q.x()), hi_x = std::max(hi_x, q.x()), lo_y = std::min(lo_y, q.y()),
    hi_y = std::max(hi_y, q.y());
  const double span = std::max({hi_x - lo_x, hi_y - lo_y, 1e-3});
  const double k = (kPanelPx - 16) / span;  // equal scales: the surface's true shape
  const double cx = x0 + kPanelPx / 2.0 - k * (lo_x + hi_x) / 2;
  const double cy = y0 + kPanelPx / 2.0 + k * (lo_y + hi_y) / 2;
  const size_t stride = std::max<size_t>(1, p.xy_mm.size() / kMaxPanelPoints);
  for (size_t i = 0; i < p.xy_mm.size(); i += stride)
    s << "<circle cx='" << Num(cx + k * p.xy_mm[i].x(), 1) << "' cy='"
      << Num(cy - k * p.xy_mm[i].y(), 1) << "' r='1.6' fill='" << Colour(p.deviation_mm[i] / scale)
      << "'/>\n";
  s << "<text x='" << x0 + kPanelPx - 4 << "' y='" << y0 + kPanelPx - 4
    << "' font-size='10' text-anchor='end' fill='#555'>" << Num(span, 1) << " mm across</text>\n";
}

}  // namespace

DeviationPanel FacePanel(const std::string& title,
                         const geometry::Points3& points,
                         const PlaneMeasurement& face) {
  geometry::Vec3 u, v;
  PlaneAxes(face.plane.normal, &u, &v);
  DeviationPanel p;
  p.title = title;
  for (Eigen::Index i : face.used) {
    const geometry::Vec3 d = points.col(i) - face.plane.point;
    p.xy_mm.emplace_back(d.dot(u), d.dot(v));
    p.deviation_mm.push_back(d.dot(face.plane.normal));
  }
  return p;
}

DeviationPanel PointsPanel(const std::string& title,
                           const geometry::Points3& points,
                           const std::vector<double>& deviation_mm,
                           const geometry::Vec3& normal) {
  geometry::Vec3 u, v;
  PlaneAxes(normal.normalized(), &u, &v);
  DeviationPanel p;
  p.title = title;
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    p.xy_mm.emplace_back(points.col(i).dot(u), points.col(i).dot(v));
  p.deviation_mm = deviation_mm;
  return p;
}

DeviationPanel RingPanel(const std::string& title, const BoreMeasurement& hole) {
  geometry::Vec3 u, v;
  PlaneAxes(hole.axis_mcs, &u, &v);
  DeviationPanel p;
  p.title = title;
  const auto& dev = hole.deviation_by_degree_mm;
  for (size_t b = 0; b < dev.size(); ++b) {
    if (!std::isfinite(dev[b])) continue;
    const double a = (static_cast<double>(b) + 0.5) / base::kDegPerRad, r = hole.diameter_mm / 2;
    p.xy_mm.emplace_back(r * std::cos(a), r * std::sin(a));
    p.deviation_mm.push_back(dev[b]);
  }
  return p;
}

std::string FeatureReportSvg(const FeatureReport& r) {
  const double scale = ColourScale(r.panels);
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='900' height='500' "
       "font-family='sans-serif'>\n"
    << "<rect width='900' height='500' fill='white'/>\n";
  for (size_t k = 0; k < std::min<size_t>(4, r.panels.size()); ++k) {
    const size_t column = k % 2, row = k / 2;  // two panels a row
    Panel(s, r.panels[k], 20 + 230.0 * static_cast<double>(column),
          40 + 240.0 * static_cast<double>(row), scale);
  }
  const double y0 = 40, dy = 22;
  int line = 0;
  const auto text = [&](const std::string& t, int size, const std::string& colour) {
    s << "<text x='480' y='" << Num(y0 + dy * line++, 0) << "' font-size='" << size << "' fill='"
      << colour << "'>" << SvgText(t) << "</text>\n";
  };
  text(r.title, 16, "black");
  text(r.verdict, 22, VerdictColour(r.verdict));
  for (const auto& l : r.lines) text(l, 13, "black");
  if (!r.panels.empty())
    text("colour: blue below, red above (+-" + Num(scale * 1e3, 1) + " um: 99 % of the points)", 12,
         "#555");
  text(r.decision.size() > 60 ? r.decision.substr(0, 60) + "..." : r.decision, 12, "black");
  text(r.time_utc, 11, "#777");
  s << "</svg>\n";
  return s.str();
}

}  // namespace mlp::features
