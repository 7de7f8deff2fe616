#include "mlp/calib/trunnion_report.h"

#include "mlp/base/format.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace mlp::calib {
namespace {

using base::Fixed;

// One reported quantity: the pin's value, what the centres say, its uncertainty and limit.
struct Row {
  std::string name;
  double pin, found, u, limit;
  bool Within() const { return std::abs(found - pin) <= limit; }
};

std::vector<Row> PivotRows(const TrunnionFit& fit, const TrtPins& pins, double limit_mm) {
  const TrtPins to = PinsFor(fit, pins);
  return {
      {"x-rot-point", pins.x_rot_point, to.x_rot_point, fit.c_x_u_mm, limit_mm},
      {"y-rot-point", pins.y_rot_point, to.y_rot_point, fit.c_y_u_mm, limit_mm},
      {"y-offset", pins.y_offset, to.y_offset, std::hypot(fit.a_y_u_mm, fit.c_y_u_mm), limit_mm},
      {"z-offset", pins.z_offset, to.z_offset, fit.a_z_u_mm, limit_mm}};
}

std::vector<Row> SquareRows(const TrunnionFit& fit, double limit_deg) {
  return {{"A from X about Z", 0, fit.a_about_z_deg, fit.a_about_z_u_deg, limit_deg},
          {"A from X about Y", 0, fit.a_about_y_deg, fit.a_about_y_u_deg, limit_deg},
          {"C from Z about X (A zero)", 0, fit.c_about_x_deg, fit.c_about_x_u_deg, limit_deg},
          {"C from Z about Y", 0, fit.c_about_y_deg, fit.c_about_y_u_deg, limit_deg},
          {"A to C from square", 0, fit.a_c_square_deg, fit.a_c_square_u_deg, limit_deg}};
}

nlohmann::ordered_json RowsJson(const std::vector<Row>& rows) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const Row& r : rows) {
    out.push_back({{"name", r.name},
                   {"controller", r.pin},
                   {"found", r.found},
                   {"error", r.found - r.pin},
                   {"u", r.u},
                   {"limit", r.limit},
                   {"within", r.Within()}});
  }
  return out;
}

// A panel: data (x, y) in [x0, x1] x [y0, y1] drawn into a square of `size` px at (left, top).
struct Panel {
  double left, top, size, x0, x1, y0, y1;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * size; }
  double Y(double y) const { return top + size - (y - y0) / (y1 - y0) * size; }
};

// A square panel about the points (equal scales, 15 % margin).
Panel Around(const std::vector<std::pair<double, double>>& pts, double left, double top) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& [x, y] : pts)
    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  const double half = 0.65 * std::max({x1 - x0, y1 - y0, 1.0});
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  return {left, top, 320, cx - half, cx + half, cy - half, cy + half};
}

const char* ColourOf(double a_deg) {
  static const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                         "#ff7f0e", "#8c564b", "#e377c2"};
  return kColours[static_cast<size_t>(std::lround(std::abs(a_deg))) % 7];
}

void Mark(std::ostringstream& s, double x, double y, const char* colour, const std::string& label) {
  s << "<path d='M" << Fixed(x - 6, 1) << ' ' << Fixed(y, 1) << "h12M" << Fixed(x, 1) << ' '
    << Fixed(y - 6, 1) << "v12' stroke='" << colour << "' stroke-width='2'/>\n";
  s << "<text x='" << Fixed(x + 8, 1) << "' y='" << Fixed(y - 8, 1) << "' font-size='11' fill='"
    << colour << "'>" << label << "</text>\n";
}

// One view of the centres: (u, v) picks the coordinates; the fitted axis' and the pins' points.
void View(std::ostringstream& s,
          const std::vector<TrunnionObservation>& centres,
          int u,
          int v,
          const Vec3& fitted,
          const Vec3& pinned,
          double left,
          const std::string& title) {
  std::vector<std::pair<double, double>> pts;
  pts.reserve(centres.size() + 1);
  for (const auto& c : centres) pts.emplace_back(c.centre_machine_mm[u], c.centre_machine_mm[v]);
  pts.emplace_back(fitted[u], fitted[v]);
  const Panel p = Around(pts, left, 50);
  s << "<rect x='" << left << "' y='50' width='320' height='320' fill='none' stroke='#888'/>\n"
    << "<text x='" << left << "' y='40' font-size='13'>" << title << "</text>\n";
  for (const auto& c : centres) {
    s << "<circle cx='" << Fixed(p.X(c.centre_machine_mm[u]), 1) << "' cy='"
      << Fixed(p.Y(c.centre_machine_mm[v]), 1) << "' r='4' fill='" << ColourOf(c.a_deg)
      << "'><title>A " << Fixed(c.a_deg, 3) << " C " << Fixed(c.c_deg, 3) << "</title></circle>\n";
  }
  Mark(s, p.X(fitted[u]), p.Y(fitted[v]), "#000", "axis found");
  Mark(s, p.X(pinned[u]), p.Y(pinned[v]), "#888", "pins");
}

// Horizontal bars of errors [um] against +-limit.
void Bars(std::ostringstream& s,
          const std::vector<Row>& rows,
          double scale,
          const char* unit,
          double top) {
  constexpr double kLeft = 900, kHalf = 150;
  double worst = 0;
  for (const Row& r : rows) worst = std::max({worst, std::abs(r.found - r.pin), r.limit});
  const double k = kHalf / (worst * scale);
  const double lim = rows.front().limit * scale * k;
  s << "<path d='M" << Fixed(kLeft - lim, 1) << ' ' << top - 12 << "v" << 22 * rows.size() << "M"
    << Fixed(kLeft + lim, 1) << ' ' << top - 12 << "v" << 22 * rows.size()
    << "' stroke='#d62728' stroke-dasharray='4 3'/>\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const double e = (r.found - r.pin) * scale, y = top + 22.0 * static_cast<double>(i);
    s << "<rect x='" << Fixed(kLeft + std::min(0.0, e * k), 1) << "' y='" << Fixed(y - 8, 1)
      << "' width='" << Fixed(std::abs(e * k), 1) << "' height='12' fill='"
      << (r.Within() ? "#2ca02c" : "#d62728") << "'/>\n"
      << "<text x='" << kLeft - kHalf - 10 << "' y='" << Fixed(y + 2, 1)
      << "' font-size='11' text-anchor='end'>" << r.name << ": " << Fixed(e, 2) << " " << unit
      << " +- " << Fixed(r.u * scale, 2) << "</text>\n";
  }
}

void PrintRows(
    std::ostream& out, const std::vector<Row>& rows, double scale, const char* unit, int decimals) {
  for (const Row& r : rows) {
    out << "  " << r.name << ": " << Fixed((r.found - r.pin) * scale, decimals) << " " << unit
        << " +- " << Fixed(r.u * scale, decimals) << " (limit " << Fixed(r.limit * scale, decimals)
        << ")" << (r.Within() ? "" : "  BEYOND") << "\n";
  }
}

}  // namespace

bool TrunnionWithin(const TrunnionFit& fit, const TrtPins& pins, const TrunnionLimits& limits) {
  bool within = true;
  for (const Row& r : PivotRows(fit, pins, limits.pivot_mm)) within = within && r.Within();
  for (const Row& r : SquareRows(fit, limits.square_deg)) within = within && r.Within();
  return within;
}

nlohmann::ordered_json TrunnionReportJson(const std::vector<TrunnionObservation>& centres,
                                          const TrunnionFit& fit,
                                          const TrtPins& pins,
                                          const TrunnionLimits& limits) {
  const TrtPins to = PinsFor(fit, pins);
  return {{"within", TrunnionWithin(fit, pins, limits)},
          {"centres", centres.size()},
          {"residual_rms_mm", fit.residual_rms_mm},
          {"residual_mm", fit.residual_mm},
          {"pivots_mm", RowsJson(PivotRows(fit, pins, limits.pivot_mm))},
          {"squareness_deg", RowsJson(SquareRows(fit, limits.square_deg))},
          {"pins_that_fit",
           {{"x-rot-point", to.x_rot_point},
            {"y-rot-point", to.y_rot_point},
            {"y-offset", to.y_offset},
            {"z-offset", to.z_offset}}}};
}

std::string TrunnionReportText(const std::vector<TrunnionObservation>& centres,
                               const TrunnionFit& fit,
                               const TrtPins& pins,
                               const TrunnionLimits& limits) {
  std::ostringstream out;
  out << "trunnion check over " << centres.size() << " sphere centres: residual "
      << Fixed(fit.residual_rms_mm * 1e3, 2) << " um RMS, worst "
      << Fixed(*std::max_element(fit.residual_mm.begin(), fit.residual_mm.end()) * 1e3, 2)
      << " um\n pivots against the pins (found - pin, k = 1):\n";
  PrintRows(out, PivotRows(fit, pins, limits.pivot_mm), 1e3, "um", 1);
  out << " squareness, which the kinematics cannot hold:\n";
  PrintRows(out, SquareRows(fit, limits.square_deg), 1.0, "deg", 4);
  return out.str();
}

std::string TrunnionSvg(const std::vector<TrunnionObservation>& centres,
                        const TrunnionFit& fit,
                        const TrtPins& pins,
                        double limit_mm) {
  const TrunnionAxes nominal = AxesOf(pins);
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='1120' height='420' "
       "font-family='sans-serif'>\n"
    << "<rect width='1120' height='420' fill='white'/>\n";
  std::vector<TrunnionObservation> at_zero;
  for (const auto& c : centres)
    if (std::abs(c.a_deg) < 1e-6) at_zero.push_back(c);
  View(s, centres, 1, 2, fit.axes.a.point, nominal.a.point, 30,
       "seen along X: the centres turn about A (colour: A)");
  View(s, at_zero.empty() ? centres : at_zero, 0, 1, fit.axes.c.point, nominal.c.point, 380,
       "seen along Z at A = 0: the centres turn about C");
  s << "<text x='750' y='40' font-size='13'>pivot errors against +-" << Fixed(limit_mm * 1e3, 1)
    << " um (dashed)</text>\n";
  Bars(s, PivotRows(fit, pins, limit_mm), 1e3, "um", 80);
  s << "<text x='750' y='210' font-size='13'>centre residuals: RMS "
    << Fixed(fit.residual_rms_mm * 1e3, 2) << " um over " << centres.size() << "</text>\n";
  const double worst =
      std::max(1e-6, *std::max_element(fit.residual_mm.begin(), fit.residual_mm.end()));
  for (size_t i = 0; i < fit.residual_mm.size(); ++i) {
    const double h = 120.0 * fit.residual_mm[i] / worst;
    s << "<rect x='"
      << Fixed(750 + 340.0 * static_cast<double>(i) / static_cast<double>(fit.residual_mm.size()),
               1)
      << "' y='" << Fixed(360 - h, 1) << "' width='"
      << Fixed(300.0 / static_cast<double>(fit.residual_mm.size()), 1) << "' height='"
      << Fixed(h, 1) << "' fill='" << ColourOf(centres[i].a_deg) << "'/>\n";
  }
  s << "<text x='750' y='385' font-size='11'>tallest " << Fixed(worst * 1e3, 2)
    << " um</text>\n</svg>\n";
  return s.str();
}

nlohmann::json PinChangesJson(const std::vector<PinChange>& changes) {
  nlohmann::json out = nlohmann::json::array();
  for (const PinChange& c : changes)
    out.push_back({{"name", c.name},
                   {"before_mm", c.before_mm},
                   {"after_mm", c.after_mm},
                   {"u_mm", c.u_mm},
                   {"changed", c.changed}});
  return out;
}

}  // namespace mlp::calib
