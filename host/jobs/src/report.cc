#include "mlp/jobs/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace mlp::jobs {
namespace {

constexpr double kCentreX = 240, kCentreY = 250, kBaseRadiusPx = 150;
// The largest deviation (or half the tolerance band) is drawn this many pixels off the circle.
constexpr double kMagnifiedPx = 60;

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

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

}  // namespace

std::string BoreReportSvg(const BoreReport& r) {
  const auto& dev = r.bore.deviation_by_degree_mm;
  double worst = 0;
  for (double d : dev)
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
  // Tolerance band around the nominal (radius = nominal / 2 + tolerance / 2 on either side).
  const double nominal_px = kBaseRadiusPx + k * (r.nominal_mm / 2 - fitted_r);
  Circle(s, nominal_px + k * r.upper_tol_mm / 2, "fill='none' stroke='#8fd19e' stroke-width='1.5'");
  Circle(s, nominal_px - k * r.lower_tol_mm / 2, "fill='none' stroke='#8fd19e' stroke-width='1.5'");
  Circle(s, nominal_px, "fill='none' stroke='#555' stroke-dasharray='6 4'");
  Circle(s, kBaseRadiusPx, "fill='none' stroke='black' stroke-width='1.2'");
  for (size_t b = 0; b < dev.size(); ++b) {
    if (!std::isfinite(dev[b])) continue;
    const double a = (static_cast<double>(b) + 0.5) * M_PI / 180.0;
    const double rr = kBaseRadiusPx + k * dev[b];
    // Screen y points down: machine +Y is up.
    s << "<circle cx='" << Num(kCentreX + rr * std::cos(a), 1) << "' cy='"
      << Num(kCentreY - rr * std::sin(a), 1) << "' r='2.2' fill='"
      << Colour(worst > 0 ? dev[b] / worst : 0) << "' stroke='#333' stroke-width='0.3'/>\n";
  }
  s << "<text x='" << kCentreX << "' y='" << kCentreY + 5
    << "' text-anchor='middle' font-size='12' fill='#555'>+X at 3 o'clock</text>\n";
  const double y0 = 40, dy = 24;
  int line = 0;
  const auto text = [&](const std::string& t, int size, const std::string& colour) {
    s << "<text x='470' y='" << Num(y0 + dy * line++, 0) << "' font-size='" << size << "' fill='"
      << colour << "'>" << Escape(t) << "</text>\n";
  };
  text(r.title, 16, "black");
  text(r.verdict, 22, VerdictColour(r.verdict));
  text("size " + Num(r.size_mm, 4) + " mm (nominal " + Num(r.nominal_mm, 3) + " +" +
           Num(r.upper_tol_mm, 3) + "/-" + Num(r.lower_tol_mm, 3) + ")",
       13, "black");
  text("error " + Num(r.error_mm * 1e3, 1) + " um", 13, "black");
  text("least squares D " + Num(r.bore.diameter_mm, 4) + " mm", 13, "black");
  if (r.bore.functional_diameter_mm > 0)
    text("max inscribed D " + Num(r.bore.functional_diameter_mm, 4) + " mm", 13, "black");
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
  s << "</svg>\n";
  return s.str();
}

}  // namespace mlp::jobs
