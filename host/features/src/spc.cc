#include "mlp/features/spc.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "svg_text.h"

namespace mlp::features {
namespace {

constexpr double kD2 = 1.128;   // d2 for ranges of two values (ASTM E2587, table)
constexpr int kFewValues = 25;  // AIAG SPC manual: at least 25 subgroups

[[noreturn]] void Fail(const std::string& why) { throw SpcError("spc: " + why); }

}  // namespace

CapabilityStudy StudyCapability(const std::vector<double>& values, const SpcLimits& limits) {
  if (values.size() < 2) Fail("capability needs at least two values");
  for (double v : values)
    if (!std::isfinite(v)) Fail("a value is not finite");
  if (!(std::isfinite(limits.lower) && std::isfinite(limits.upper) && limits.lower < limits.upper))
    Fail("the lower specification limit must be below the upper");
  CapabilityStudy s;
  s.n = static_cast<int>(values.size());
  const auto n = static_cast<double>(values.size());
  for (double v : values) s.mean += v / n;
  double square = 0, range = 0;
  for (double v : values) square += (v - s.mean) * (v - s.mean);
  for (size_t i = 1; i < values.size(); ++i) range += std::abs(values[i] - values[i - 1]);
  s.sigma_overall = std::sqrt(square / (n - 1));
  s.sigma_within = range / (n - 1) / kD2;
  if (!(s.sigma_within > 0) || !(s.sigma_overall > 0))
    Fail("every value is the same: no spread, so no capability (finer resolution needed)");
  const double width = limits.upper - limits.lower;
  const double nearest = std::min(limits.upper - s.mean, s.mean - limits.lower);
  s.cp = width / (6 * s.sigma_within), s.cpk = nearest / (3 * s.sigma_within);
  s.pp = width / (6 * s.sigma_overall), s.ppk = nearest / (3 * s.sigma_overall);
  s.lcl = s.mean - 3 * s.sigma_within, s.ucl = s.mean + 3 * s.sigma_within;
  for (size_t i = 0; i < values.size(); ++i) {
    if (values[i] < limits.lower || values[i] > limits.upper) ++s.out_of_spec;
    if (values[i] < s.lcl || values[i] > s.ucl) s.out_of_control.push_back(static_cast<int>(i));
  }
  s.few_values = s.n < kFewValues;
  return s;
}

// Written by hand: SVG is text, and no C++ plotting library is in Debian that would be lighter
// than these lines (OpenCV draws pixels, not a chart a person zooms into).
std::string RunChartSvg(const std::vector<double>& values,
                        const SpcLimits& limits,
                        const CapabilityStudy& s,
                        const std::string& title,
                        const std::string& unit) {
  constexpr double kW = 800, kH = 360, kLeft = 90, kRight = 20, kTop = 40, kBottom = 40;
  double lo = std::min({limits.lower, s.lcl, *std::min_element(values.begin(), values.end())});
  double hi = std::max({limits.upper, s.ucl, *std::max_element(values.begin(), values.end())});
  const double pad = 0.05 * (hi - lo);
  lo -= pad, hi += pad;
  const auto x = [&](size_t i) {
    return kLeft + (kW - kLeft - kRight) *
                       (values.size() == 1
                            ? 0.5
                            : static_cast<double>(i) / static_cast<double>(values.size() - 1));
  };
  const auto y = [&](double v) { return kTop + (kH - kTop - kBottom) * (hi - v) / (hi - lo); };
  std::ostringstream o;
  o << std::fixed << std::setprecision(2);
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kW << "\" height=\"" << kH
    << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
    << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    << "<text x=\"" << kLeft << "\" y=\"22\" font-size=\"14\">" << SvgText(title) << ": n " << s.n
    << ", Cp " << s.cp << ", Cpk " << s.cpk << ", Ppk " << s.ppk
    << (s.few_values ? " (fewer than 25 values)" : "") << "</text>\n";
  const auto line = [&](double v, const char* colour, const char* dash, const std::string& name) {
    o << "<line x1=\"" << kLeft << "\" x2=\"" << kW - kRight << "\" y1=\"" << y(v) << "\" y2=\""
      << y(v) << "\" stroke=\"" << colour << "\" stroke-dasharray=\"" << dash << "\"/>\n"
      << "<text x=\"4\" y=\"" << y(v) + 4 << "\" fill=\"" << colour << "\">" << name << " "
      << std::setprecision(4) << v << std::setprecision(2) << "</text>\n";
  };
  line(limits.upper, "red", "6,3", "USL");
  line(limits.lower, "red", "6,3", "LSL");
  line(s.ucl, "darkorange", "2,3", "UCL");
  line(s.lcl, "darkorange", "2,3", "LCL");
  line(s.mean, "green", "none", "mean");
  o << "<polyline fill=\"none\" stroke=\"steelblue\" points=\"";
  for (size_t i = 0; i < values.size(); ++i) o << x(i) << "," << y(values[i]) << " ";
  o << "\"/>\n";
  for (size_t i = 0; i < values.size(); ++i) {
    const bool out = values[i] < limits.lower || values[i] > limits.upper;
    o << "<circle cx=\"" << x(i) << "\" cy=\"" << y(values[i]) << "\" r=\"3\" fill=\""
      << (out ? "red" : "steelblue") << "\"/>\n";
  }
  o << "<text x=\"" << kLeft << "\" y=\"" << kH - 12 << "\">part 1 .. " << s.n
    << " (oldest first), " << SvgText(unit) << "</text>\n</svg>\n";
  return o.str();
}

}  // namespace mlp::features
