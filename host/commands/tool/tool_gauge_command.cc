// `mlp tool gauge-setup` and `mlp tool gauge`: round parts from back-lit images (issue 52):
// the scale and edge bias from master parts with CMM figures, then any part measured with them.

#include "mlp/host/cli.h"
#include "mlp/toolcam/gauge.h"
#include "mlp/toolcam/tool_model.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "tool_commands.h"
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::host::tool {
namespace {

namespace fs = std::filesystem;

// A back-lit image, grey; bad input when it cannot be read.
cv::Mat ReadGrey(const std::string& path) {
  cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (m.empty()) throw UsageError("cannot read the image " + path);
  return m;
}

toolcam::GaugedPart Gauge(const cv::Mat& m) {
  return toolcam::GaugeRing({m.data, m.cols, m.rows, 0});
}

// The masters' file: "image,outer_diameter_mm,inner_diameter_mm" per line (a header line
// allowed), images relative to the file.
struct Master {
  std::string image;
  toolcam::MasterFigures cmm;
};

std::vector<Master> ReadMasters(const std::string& path) {
  std::istringstream in(ReadInputFile(path));
  std::vector<Master> out;
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::vector<std::string> f;
    std::stringstream s(line);
    for (std::string x; std::getline(s, x, ',');) f.push_back(x);
    if (f.empty() || (line_no == 1 && f[0] == "image")) continue;
    Master m;
    try {
      if (f.size() != 3) throw std::invalid_argument("3 fields");
      m.image = (fs::path(path).parent_path() / f[0]).string();
      m.cmm = {std::stod(f[1]), std::stod(f[2])};
    } catch (const std::exception&) {
      throw UsageError(path + ":" + std::to_string(line_no) +
                       ": expected image,outer_diameter_mm,inner_diameter_mm");
    }
    if (!(m.cmm.outer_diameter_mm > m.cmm.inner_diameter_mm && m.cmm.inner_diameter_mm > 0))
      throw UsageError(path + ":" + std::to_string(line_no) + ": outer > inner > 0 mm");
    out.push_back(m);
  }
  if (out.size() < 2) throw UsageError(path + ": the scale needs two masters or more");
  return out;
}

toolcam::GaugeScale ReadScale(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(ReadInputFile(path));
    if (j.at("format") != "mlprobe-gauge-scale/1") throw std::invalid_argument("format");
    toolcam::GaugeScale s;
    s.mm_per_px = j.at("mm_per_px").get<double>();
    s.edge_bias_mm = j.at("edge_bias_mm").get<double>();
    s.rms_mm = j.value("masters_rms_mm", 0.0);
    s.masters = j.value("masters", 0);
    s.mm_per_px_u = j.value("mm_per_px_u", 0.0);
    s.edge_bias_u_mm = j.value("edge_bias_u_mm", 0.0);
    s.correlation = j.value("correlation", 0.0);
    if (!(s.mm_per_px > 0) || !std::isfinite(s.edge_bias_mm)) throw std::invalid_argument("range");
    return s;
  } catch (const std::exception&) {
    throw UsageError(path + ": not an mlprobe-gauge-scale/1 file (mm_per_px > 0, edge_bias_mm)");
  }
}

// The part's picture: the image, each circle's sector means' deviation from its fitted circle
// magnified x50 (red), the fitted circles (green), what was left out counted on top.
void Picture(const std::string& path,
             const cv::Mat& grey,
             const toolcam::GaugedPart& p,
             const toolcam::PartFigures& f) {
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  constexpr double kMagnify = 50;
  for (const toolcam::GaugedCircle* c : {&p.outer, &p.inner}) {
    const double r = c->diameter_px / 2;
    cv::circle(img, {int(std::lround(c->centre_px.x())), int(std::lround(c->centre_px.y()))},
               int(std::lround(r)), {0, 200, 0}, 2, cv::LINE_AA);
    std::vector<cv::Point> dev;
    for (const auto& m : c->sector_means_px) {
      const geometry::Vec2 d = m - c->centre_px;
      const geometry::Vec2 q = c->centre_px + d.normalized() * (r + kMagnify * (d.norm() - r));
      dev.emplace_back(int(std::lround(q.x())), int(std::lround(q.y())));
    }
    cv::polylines(img, dev, true, {0, 0, 230}, 2, cv::LINE_AA);
  }
  std::ostringstream t;
  t << std::fixed << std::setprecision(4) << "outer " << f.outer_diameter_mm << " inner "
    << f.inner_diameter_mm << " mm, concentricity " << std::setprecision(1)
    << f.concentricity_mm * 1e3 << " um; left out " << p.outer.left_out + p.inner.left_out
    << " (deviations x50)";
  cv::putText(img, t.str(), {20, 50}, cv::FONT_HERSHEY_SIMPLEX, 1.4, {0, 0, 160}, 3, cv::LINE_AA);
  if (!cv::imwrite(path, img)) throw UsageError("cannot write " + path);
}

nlohmann::ordered_json CircleJson(
    const toolcam::GaugedCircle& c, double d, double u, double lo, double hi, double roundness) {
  return {{"diameter_mm", d},      {"diameter_u_mm", u},        {"min_diameter_mm", lo},
          {"max_diameter_mm", hi}, {"roundness_mm", roundness}, {"points", c.points},
          {"left_out", c.left_out}};
}

}  // namespace

int GaugeSetup(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--masters", "--out"}, {"--json"}});
  if (f.Text("--masters", "").empty() || f.Text("--out", "").empty())
    throw UsageError("mlp tool gauge-setup needs --masters FILE.csv and --out SCALE.json");
  const std::vector<Master> masters = ReadMasters(f.Text("--masters", ""));
  std::vector<toolcam::GaugedPart> parts;
  std::vector<toolcam::MasterFigures> cmm;
  for (const Master& m : masters) {
    err << "mlp tool: gauging master " << m.image << "\n";
    parts.push_back(Gauge(ReadGrey(m.image)));
    cmm.push_back(m.cmm);
  }
  const toolcam::GaugeScale s = toolcam::FitGaugeScale(parts, cmm);
  const nlohmann::ordered_json j = {{"format", "mlprobe-gauge-scale/1"},
                                    {"mm_per_px", s.mm_per_px},
                                    {"edge_bias_mm", s.edge_bias_mm},
                                    {"masters_rms_mm", s.rms_mm},
                                    {"masters", s.masters},
                                    {"mm_per_px_u", s.mm_per_px_u},
                                    {"edge_bias_u_mm", s.edge_bias_u_mm},
                                    {"correlation", s.correlation}};
  WriteOutputFile(f.Text("--out", ""), j.dump(1) + "\n");
  if (f.Has("--json")) {
    out << j.dump() << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(7) << "gauge scale from " << s.masters
      << " masters: " << s.mm_per_px << " mm/px, edge bias " << std::setprecision(2)
      << s.edge_bias_mm * 1e3 << " um (u " << s.edge_bias_u_mm * 1e3
      << " um); the masters' diameters about it " << s.rms_mm * 1e3
      << " um RMS: a part's diameter is known to about that (k = 1)\n  written to "
      << f.Text("--out", "") << "\n";
  return kExitOk;
}

int GaugeOne(const std::vector<std::string>& args, std::ostream& out, std::ostream& /*err*/) {
  const Args f(args, {{"--image", "--scale", "--png"}, {"--json"}});
  if (f.Text("--image", "").empty() || f.Text("--scale", "").empty())
    throw UsageError("mlp tool gauge needs --image PART.png and --scale SCALE.json");
  const toolcam::GaugeScale s = ReadScale(f.Text("--scale", ""));
  const cv::Mat grey = ReadGrey(f.Text("--image", ""));
  toolcam::GaugedPart p;
  try {
    p = Gauge(grey);
  } catch (const toolcam::GaugeError& e) {
    throw toolcam::ToolError(e.what());  // exit 3: no number
  }
  const toolcam::PartFigures m = toolcam::ToMillimetres(p, s);
  if (!f.Text("--png", "").empty()) Picture(f.Text("--png", ""), grey, p, m);
  const nlohmann::ordered_json j = {
      {"image", f.Text("--image", "")},
      {"outer", CircleJson(p.outer, m.outer_diameter_mm, m.outer_diameter_u_mm, m.outer_min_mm,
                           m.outer_max_mm, m.outer_roundness_mm)},
      {"inner", CircleJson(p.inner, m.inner_diameter_mm, m.inner_diameter_u_mm, m.inner_min_mm,
                           m.inner_max_mm, m.inner_roundness_mm)},
      {"concentricity_mm", m.concentricity_mm},
      {"concentricity_rule", "ISO 1101: the zone's diameter, twice the centres' distance"},
      {"centre_distance_mm", m.centre_distance_mm},
      {"stray_points", p.stray_points},
      {"left_out_rule", "edge points over 3 px (and 4 robust sigma) off their circle"}};
  if (f.Has("--json")) {
    out << j.dump() << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(4) << f.Text("--image", "") << ": outer "
      << m.outer_diameter_mm << " mm +-" << std::setprecision(1) << 2e3 * m.outer_diameter_u_mm
      << " um (k = 2; " << std::setprecision(4) << m.outer_min_mm << " .. " << m.outer_max_mm
      << ", roundness " << std::setprecision(1) << m.outer_roundness_mm * 1e3 << " um), inner "
      << std::setprecision(4) << m.inner_diameter_mm << " mm +-" << std::setprecision(1)
      << 2e3 * m.inner_diameter_u_mm << " um (k = 2; " << std::setprecision(4) << m.inner_min_mm
      << " .. " << m.inner_max_mm << ", roundness " << std::setprecision(1)
      << m.inner_roundness_mm * 1e3 << " um), concentricity " << m.concentricity_mm * 1e3
      << " um (ISO 1101 zone diameter; centres " << m.centre_distance_mm * 1e3
      << " um apart)\n  edge points: " << p.outer.points << " + " << p.inner.points << " used, "
      << p.outer.left_out << " + " << p.inner.left_out
      << " left out (over 3 px and 4 robust sigma off the circle), " << p.stray_points
      << " stray (dust off the part)\n";
  if (!f.Text("--png", "").empty()) out << "  picture: " << f.Text("--png", "") << "\n";
  return kExitOk;
}

}  // namespace mlp::host::tool
