#include "verify_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace mlp::host {
namespace {

using json = nlohmann::json;

constexpr double kPanelW = 400, kPanelH = 300, kTop = 60, kLeft = 70, kGap = 110;
const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};

// A panel's data-to-picture mapping: x in [x0, x1], y in [y0, y1].
struct Axes {
  double left, x0, x1, y0, y1;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * kPanelW; }
  double Y(double y) const { return kTop + kPanelH - (y - y0) / (y1 - y0) * kPanelH; }
};

bool Within(const json& finish) {
  for (const json& t : finish["tests"])
    if (!t["within"].get<bool>()) return false;
  return true;
}

std::string Num(double v, int decimals = 1) {
  char b[32];
  std::snprintf(b, sizeof b, "%.*f", decimals, v);
  return b;
}

void Frame(std::ostringstream& s,
           const Axes& a,
           const std::string& title,
           const std::string& x,
           const std::string& y) {
  s << "<rect x='" << a.left << "' y='" << kTop << "' width='" << kPanelW << "' height='" << kPanelH
    << "' fill='none' stroke='#444'/>\n"
    << "<text x='" << a.left + kPanelW / 2 << "' y='" << kTop - 12
    << "' text-anchor='middle' font-weight='bold'>" << title << "</text>\n"
    << "<text x='" << a.left + kPanelW / 2 << "' y='" << kTop + kPanelH + 36
    << "' text-anchor='middle'>" << x << "</text>\n"
    << "<text x='" << a.left - 48 << "' y='" << kTop + kPanelH / 2 << "' text-anchor='middle' "
    << "transform='rotate(-90 " << a.left - 48 << " " << kTop + kPanelH / 2 << ")'>" << y
    << "</text>\n";
  for (int k = 0; k <= 4; ++k) {  // y ticks
    const double v = a.y0 + (a.y1 - a.y0) * k / 4;
    s << "<text x='" << a.left - 6 << "' y='" << a.Y(v) + 4 << "' text-anchor='end'>" << Num(v)
      << "</text>\n";
  }
  for (int k = 0; k <= 4; ++k) {  // x ticks
    const double v = a.x0 + (a.x1 - a.x0) * k / 4;
    s << "<text x='" << a.X(v) << "' y='" << kTop + kPanelH + 16 << "' text-anchor='middle'>"
      << Num(v, 0) << "</text>\n";
  }
}

void Line(std::ostringstream& s, double x0, double y0, double x1, double y1, const char* style) {
  s << "<line x1='" << x0 << "' y1='" << y0 << "' x2='" << x1 << "' y2='" << y1 << "' " << style
    << "/>\n";
}

// E_Uni of every length of every finish, with the envelope +-(A + L/K).
void LengthPanel(std::ostringstream& s, const json& r) {
  const double a_um = r["mpe"]["e_uni_a_um"], k = r["mpe"]["e_uni_k"];
  double l_max = 50;
  for (const json& f : r["finishes"])
    for (const json& e : f["lengths"]) l_max = std::max(l_max, e["length_mm"].get<double>());
  const double y = 1.2 * (a_um + l_max / k);
  const Axes ax{kLeft, 0, l_max * 1.1, -y, y};
  Frame(s, ax, "E_Uni: length error [um]", "length L [mm]", "E [um]");
  const char* mpe = "stroke='#888' stroke-dasharray='6 4'";
  Line(s, ax.X(0), ax.Y(a_um), ax.X(ax.x1), ax.Y(a_um + ax.x1 / k), mpe);
  Line(s, ax.X(0), ax.Y(-a_um), ax.X(ax.x1), ax.Y(-a_um - ax.x1 / k), mpe);
  Line(s, ax.X(0), ax.Y(0), ax.X(ax.x1), ax.Y(0), "stroke='#ccc'");
  size_t c = 0;
  for (const json& f : r["finishes"]) {
    for (const json& e : f["lengths"])
      s << "<circle cx='" << ax.X(e["length_mm"]) << "' cy='" << ax.Y(e["e_um"])
        << "' r='3.5' fill='" << kColours[c % 4] << "'><title>" << f["material"].get<std::string>()
        << " " << e["orientation"].get<std::string>() << " L " << Num(e["length_mm"], 0)
        << " mm: " << Num(e["e_um"], 2) << " um</title></circle>\n";
    ++c;
  }
}

// Every probing view's P_Form.Sph.D95% (circles) and 1x25 (squares) against their MPEs.
void ProbingPanel(std::ostringstream& s, const json& r, double left) {
  const double form = r["mpe"]["p_form_sph_1x25_um"], disp = r["mpe"]["p_form_sph_d95_um"];
  double y = std::max(form, disp);
  size_t views = 1;
  for (const json& f : r["finishes"]) {
    views = std::max(views, f["views"].size());
    for (const json& v : f["views"])
      y = std::max({y, v["p_form_d95_um"].get<double>(), v["p_form_1x25_um"].get<double>()});
  }
  const Axes ax{left, 0, static_cast<double>(views + 1), 0, 1.15 * y};
  Frame(s, ax, "probing form: D95% (o), 1x25 (square) [um]", "view", "range [um]");
  Line(s, ax.X(0), ax.Y(form), ax.X(ax.x1), ax.Y(form), "stroke='#888' stroke-dasharray='6 4'");
  Line(s, ax.X(0), ax.Y(disp), ax.X(ax.x1), ax.Y(disp), "stroke='#bbb' stroke-dasharray='2 3'");
  size_t c = 0;
  for (const json& f : r["finishes"]) {
    double i = 1 + 0.15 * static_cast<double>(c);
    for (const json& v : f["views"]) {
      s << "<circle cx='" << ax.X(i) << "' cy='" << ax.Y(v["p_form_d95_um"]) << "' r='3.5' fill='"
        << kColours[c % 4] << "'/>\n<rect x='" << ax.X(i) - 3.5 << "' y='"
        << ax.Y(v["p_form_1x25_um"]) - 3.5 << "' width='7' height='7' fill='none' stroke='"
        << kColours[c % 4] << "'/>\n";
      i += 1;
    }
    ++c;
  }
}

}  // namespace

std::string VerifyPlotSvg(const json& r) {
  const double width = 2 * kLeft + 2 * kPanelW + kGap, height = kTop + kPanelH + 90;
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << width << "' height='" << height
    << "' font-family='sans-serif' font-size='12'>\n"
    << "<rect width='100%' height='100%' fill='white'/>\n"
    << "<text x='" << kLeft << "' y='22' font-size='14' font-weight='bold'>mlp verify - "
    << r["world"].get<std::string>() << "</text>\n";
  LengthPanel(s, r);
  ProbingPanel(s, r, kLeft + kPanelW + kGap);
  double x = kLeft;
  size_t c = 0;
  for (const json& f : r["finishes"]) {  // legend
    s << "<circle cx='" << x << "' cy='" << height - 18 << "' r='4' fill='" << kColours[c % 4]
      << "'/><text x='" << x + 8 << "' y='" << height - 14 << "'>"
      << f["material"].get<std::string>() << (Within(f) ? "" : " (beyond an MPE)") << "</text>\n";
    x += 180;
    ++c;
  }
  s << "<text x='" << x << "' y='" << height - 14
    << "'>dashed: the MPEs (E_Uni +-(A + L/K); P_Form.Sph.1x25; dotted: D95%)</text>\n</svg>\n";
  return s.str();
}

}  // namespace mlp::host
