#include "mlp/host/tool_command.h"

#include "mlp/host/cli.h"
#include "mlp/probe_fw/json_fields.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/strobe.h"
#include "mlp/toolcam/tool_camera.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::host {
namespace {

constexpr int kExitCannotPlan = 3;
constexpr const char* kUsage =
    "usage: mlp tool strobe --rpm R --fps F --resolution-deg D [--free-running]\n"
    "                       [--timer-us T] [--min-pulse-us P] [--blanking-us B]\n"
    "                       [--max-duration-s S] [--rpm-tolerance X] [--json]\n"
    "  the strobe for shadow images of a tool turning at R rpm, a camera at F images/s, a\n"
    "  position every D degrees: pulse width, pulses per image, when they fire, the order of\n"
    "  the positions (docs/TOOLCAM.md)\n"
    "       mlp tool render --tool TOOL.json --out DIR --rpm R --fps F --resolution-deg D\n"
    "                       [--seed N] [--start-deg A] [strobe options]\n"
    "  the virtual tool camera: the plan's shadow frames (DIR/frame_NNNN.pgm) and their truth\n"
    "  (DIR/truth.json); the tool description format: docs/TOOLCAM.md\n"
    "       mlp tool measure --images DIR --tool NOMINAL.json [--overlay FILE.png] [--json]\n"
    "                        [--save-reference TOOL.json]\n"
    "  each edge's radius and length, wear and build-up from DIR/images.json (the images and\n"
    "  their angular positions, the camera's calibration) against the tool's description (a\n"
    "  stored reference: what changed since); --save-reference stores this measurement as the\n"
    "  tool's new reference\n"
    "exit codes: 0 done, 2 bad arguments, tool file or images, 3 cannot be planned or\n"
    "measured (the reason is printed), 1 bug\n";

double Number(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (end == v.c_str() || *end != '\0' || !std::isfinite(x))
    throw UsageError(flag + " takes a number, not \"" + v + "\"");
  return x;
}

struct RenderOptions {
  std::string tool, out;
  unsigned seed = 1;
  double start_deg = 17.0;  // the tool's angle at the first image: unknown to a measurement
};

toolcam::StrobeRequest Parse(const std::vector<std::string>& args,
                             bool* json,
                             RenderOptions* render) {
  toolcam::StrobeRequest r;
  bool rpm = false, fps = false, res = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& k = args[i];
    if (k == "--json") {
      *json = true;
      continue;
    }
    if (k == "--free-running") {
      r.synchronised = false;
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(k + " needs a value");
    if (render && (k == "--tool" || k == "--out")) {
      (k == "--tool" ? render->tool : render->out) = args[++i];
      continue;
    }
    const double v = Number(k, args[++i]);
    if (render && k == "--seed") {
      render->seed = static_cast<unsigned>(v);
      continue;
    }
    if (render && k == "--start-deg") {
      render->start_deg = v;
      continue;
    }
    if (k == "--rpm")
      r.rpm = v, rpm = true;
    else if (k == "--fps")
      r.frame_rate_hz = v, fps = true;
    else if (k == "--resolution-deg")
      r.resolution_deg = v, res = true;
    else if (k == "--timer-us")
      r.timer_resolution_us = v;
    else if (k == "--min-pulse-us")
      r.min_pulse_us = v;
    else if (k == "--blanking-us")
      r.blanking_us = v;
    else if (k == "--max-duration-s")
      r.max_duration_s = v;
    else if (k == "--rpm-tolerance")
      r.rpm_tolerance = v;
    else
      throw UsageError("unknown argument " + k);
  }
  if (!rpm || !fps || !res) throw UsageError("--rpm, --fps and --resolution-deg are required");
  return r;
}

void Print(const toolcam::StrobePlan& p, std::ostream& out) {
  out << std::fixed << std::setprecision(2) << "strobe plan: " << p.positions << " positions, "
      << p.duration_s << " s at " << p.rpm << " rpm" << (p.rpm_changed ? " (changed)" : "")
      << "\n  pulse <= " << p.step_time_us << " us (set " << p.pulse_width_us << " us), "
      << p.pulses_per_image << " per image" << std::setprecision(1);
  if (p.pulses_per_image > 1) out << ", " << p.pulse_spacing_us << " us apart";
  out << ", " << p.pulse_rate_hz << " pulses/s\n  images step " << p.skip
      << " position(s); angle error from the timer " << std::setprecision(4)
      << p.worst_angle_error_deg << " deg\n";
  if (!p.note.empty()) out << "  " << p.note << "\n";
}

int Render(const RenderOptions& o,
           const toolcam::StrobePlan& plan,
           std::ostream& out,
           std::ostream& err) {
  toolcam::ToolDescription tool;
  try {
    tool = toolcam::LoadTool(o.tool);
  } catch (const toolcam::ToolError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitBadInput;
  }
  err << "mlp tool: rendering " << plan.positions << " frames of " << tool.id << "\n";
  const int n = toolcam::RenderToolSequence(tool, toolcam::ToolCameraModel(), plan,
                                            o.start_deg * M_PI / 180, o.seed, o.out);
  out << n << " frames and truth.json in " << o.out << "\n";
  return kExitOk;
}

// --- mlp tool measure -------------------------------------------------------------------

namespace jf = probe_fw::json_fields;

struct Images {
  toolcam::ToolCameraModel camera;
  int positions = 0;
  double blur_rad = 0;  ///< the tool's turn during a pulse
  std::vector<int> position;
  std::vector<std::vector<std::uint8_t>> pixels;
};

// DIR/images.json (`mlprobe-tool-images/1`) and the images it lists (any format OpenCV reads).
Images ReadImages(const std::string& dir) {
  const std::filesystem::path manifest = std::filesystem::path(dir) / "images.json";
  std::ifstream in(manifest);
  if (!in) throw UsageError("cannot read " + manifest.string());
  std::ostringstream text;
  text << in.rdbuf();
  const auto j =
      jf::ParseDocument<UsageError>(text.str(), "mlprobe-tool-images/1", manifest.string());
  const auto& c = jf::Object<UsageError>(j, "camera", "images.json");
  Images im;
  im.camera.width_px = jf::Integer<UsageError>(c, "width_px", "camera");
  im.camera.height_px = jf::Integer<UsageError>(c, "height_px", "camera");
  im.camera.mm_per_px = jf::Number<UsageError>(c, "mm_per_px", "camera");
  im.camera.axis_u_px = jf::Number<UsageError>(c, "axis_u_px", "camera");
  im.camera.tip_v_px = jf::Number<UsageError>(c, "tip_v_px", "camera");
  im.camera.distortion_k1 = jf::NumberOr<UsageError>(c, "distortion_k1", 0.0, "camera");
  const auto& strobe = jf::Object<UsageError>(j, "strobe", "images.json");
  im.positions = jf::Integer<UsageError>(strobe, "positions", "strobe");
  im.blur_rad = jf::NumberOr<UsageError>(strobe, "pulse_width_us", 0.0, "strobe") * 1e-6 *
                jf::Number<UsageError>(strobe, "rpm", "strobe") / 60 * 2 * M_PI;
  if (!j.contains("images") || !j.at("images").is_array())
    throw UsageError("images.json: images must list the images");
  for (const auto& e : j.at("images")) {
    const std::string file =
        (std::filesystem::path(dir) / jf::Text<UsageError>(e, "file", "image")).string();
    const cv::Mat g = cv::imread(file, cv::IMREAD_GRAYSCALE);
    if (g.empty() || g.cols != im.camera.width_px || g.rows != im.camera.height_px)
      throw UsageError("cannot read " + file + " as a " + std::to_string(im.camera.width_px) +
                       " x " + std::to_string(im.camera.height_px) + " grey image");
    im.pixels.emplace_back(g.begin<std::uint8_t>(), g.end<std::uint8_t>());
    im.position.push_back(jf::Integer<UsageError>(e, "position", "image"));
  }
  return im;
}

// Tool frame -> pixel, through the lens' distortion (the inverse of the measurement's mapping
// to first order: enough to draw).
cv::Point2d ToPixel(const geometry::Vec2& yh, const toolcam::ToolCameraModel& c) {
  const geometry::Vec2 ideal = c.PixelFromTool(yh);
  const double u = ideal.x(), v = ideal.y();
  const double cx = (c.width_px - 1) / 2.0, cy = (c.height_px - 1) / 2.0;
  const double rho2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / (cx * cx + cy * cy);
  return {cx + (u - cx) * (1 + c.distortion_k1 * rho2),
          cy + (v - cy) * (1 + c.distortion_k1 * rho2)};
}

// The principal image of every flute, side by side in rows of two: the fitted model in green,
// contamination yellow, wear blue, build-up red, the figures on top.
void WriteOverlay(const std::string& path, const Images& im, const toolcam::ToolMeasurement& m) {
  std::vector<cv::Mat> tiles;
  const cv::Scalar kColour[] = {{0, 0, 0}, {0, 220, 255}, {255, 80, 0}, {0, 0, 255}};
  for (size_t k = 0; k < m.flutes.size(); ++k) {
    const auto& f = m.flutes[k];
    const auto& px = im.pixels[static_cast<size_t>(f.frame)];
    cv::Mat grey(im.camera.height_px, im.camera.width_px, CV_8UC1,
                 const_cast<std::uint8_t*>(px.data()));
    cv::Mat tile;
    cv::cvtColor(grey, tile, cv::COLOR_GRAY2BGR);
    std::vector<cv::Point> model;
    for (const auto& p : f.model_yh) model.push_back(ToPixel(p, im.camera));
    cv::polylines(tile, model, false, cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
    for (size_t i = 0; i < f.points_yh.size(); ++i)
      if (f.point_kind[i] != toolcam::FluteMeasurement::kUsed)
        cv::circle(tile, ToPixel(f.points_yh[i], im.camera), 2, kColour[f.point_kind[i]],
                   cv::FILLED);
    std::ostringstream t;
    t.setf(std::ios::fixed);
    t.precision(4);
    t << "flute " << k + 1 << ": r " << f.radius_mm << " mm, tip " << std::showpos
      << std::setprecision(2) << f.tip_h_mm * 1e3 << std::noshowpos << " um, " << f.findings.size()
      << " finding(s)";
    cv::putText(tile, t.str(), {12, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.7, {0, 0, 160}, 2,
                cv::LINE_AA);
    tiles.push_back(tile);
  }
  if (tiles.size() % 2)
    tiles.push_back(cv::Mat(tiles[0].size(), tiles[0].type(), cv::Scalar(255, 255, 255)));
  std::vector<cv::Mat> rows;
  for (size_t k = 0; k < tiles.size(); k += 2) {
    cv::Mat row;
    cv::hconcat(tiles[k], tiles[k + 1], row);
    rows.push_back(row);
  }
  cv::Mat all;
  cv::vconcat(rows, all);
  if (!cv::imwrite(path, all)) throw UsageError("cannot write " + path);
}

nlohmann::json MeasurementJson(const toolcam::ToolDescription& tool,
                               const toolcam::ToolMeasurement& m) {
  nlohmann::json flutes = nlohmann::json::array();
  for (const auto& f : m.flutes) {
    nlohmann::json findings = nlohmann::json::array();
    for (const auto& d : f.findings)
      findings.push_back({{"kind", d.buildup ? "build-up" : "wear"},
                          {"h_mm", d.h_mm},
                          {"length_mm", d.length_mm},
                          {"max_mm", d.max_mm},
                          {"area_mm2", d.area_mm2}});
    flutes.push_back({{"image", f.frame},
                      {"angle_deg", f.angle_deg},
                      {"radius_mm", f.radius_mm},
                      {"tip_h_mm", f.tip_h_mm},
                      {"rms_mm", f.rms_mm},
                      {"points", f.points},
                      {"removed", f.removed},
                      {"findings", findings}});
  }
  return {{"tool", tool.id},
          {"radius_mm", m.radius_mm},
          {"diameter_mm", 2 * m.radius_mm},
          {"length_mm", tool.length_mm - m.tip_h_mm},
          {"runout_mm", m.runout_mm},
          {"eccentricity_mm", m.eccentricity_mm},
          {"flutes", flutes}};
}

int Measure(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  std::string images, tool_file, overlay, save_reference;
  bool json = false;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--json") {
      json = true;
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(args[i] + " needs a value");
    const std::string& v = args[++i];
    if (args[i - 1] == "--images")
      images = v;
    else if (args[i - 1] == "--tool")
      tool_file = v;
    else if (args[i - 1] == "--overlay")
      overlay = v;
    else if (args[i - 1] == "--save-reference")
      save_reference = v;
    else
      throw UsageError("unknown argument " + args[i - 1]);
  }
  if (images.empty() || tool_file.empty())
    throw UsageError("mlp tool measure needs --images and --tool");
  toolcam::ToolDescription tool;
  try {
    tool = toolcam::LoadTool(tool_file);
  } catch (const toolcam::ToolError& e) {
    throw UsageError(e.what());
  }
  const Images im = ReadImages(images);
  toolcam::MeasureOptions options;
  options.blur_rad = im.blur_rad;
  const toolcam::ToolMeasurement m =
      toolcam::MeasureTool(im.pixels, im.position, im.positions, tool, im.camera, options);
  if (!overlay.empty()) WriteOverlay(overlay, im, m);
  if (!save_reference.empty()) {  // whole or not at all: a temporary file, then rename
    const std::string tmp = save_reference + ".tmp";
    std::ofstream(tmp) << toolcam::ToJson(toolcam::ReferenceFrom(tool, m));
    std::error_code ec;
    std::filesystem::rename(tmp, save_reference, ec);
    if (ec) throw UsageError("cannot write " + save_reference + ": " + ec.message());
  }
  if (json) {
    out << MeasurementJson(tool, m).dump() << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(4) << "tool " << tool.id << ": diameter "
      << 2 * m.radius_mm << " mm, length " << tool.length_mm - m.tip_h_mm << " mm, runout "
      << std::setprecision(1) << m.runout_mm * 1e3 << " um\n";
  for (size_t k = 0; k < m.flutes.size(); ++k) {
    const auto& f = m.flutes[k];
    out << std::setprecision(4) << "  flute " << k + 1 << ": radius " << f.radius_mm << " mm, tip "
        << std::setprecision(2) << f.tip_h_mm * 1e3 << " um, rms " << f.rms_mm * 1e3 << " um\n";
    for (const auto& d : f.findings)
      out << std::setprecision(3) << "    " << (d.buildup ? "build-up" : "wear") << " at h "
          << d.h_mm << " mm: " << std::setprecision(1) << d.max_mm * 1e3 << " um, "
          << std::setprecision(3) << d.length_mm << " mm long\n";
  }
  if (!overlay.empty()) out << "  overlay: " << overlay << "\n";
  (void)err;
  return kExitOk;
}

}  // namespace

int RunToolCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
      out << kUsage;
      return kExitOk;
    }
    if (!args.empty() && args[0] == "measure")
      return Measure({args.begin() + 1, args.end()}, out, err);
    if (args.empty() || (args[0] != "strobe" && args[0] != "render"))
      throw UsageError("expected: mlp tool strobe, render or measure ...");
    bool json = false;
    RenderOptions render;
    const bool rendering = args[0] == "render";
    const toolcam::StrobeRequest r =
        Parse({args.begin() + 1, args.end()}, &json, rendering ? &render : nullptr);
    if (rendering && (render.tool.empty() || render.out.empty()))
      throw UsageError("mlp tool render needs --tool and --out");
    const toolcam::StrobePlan p = toolcam::PlanStrobe(r);
    if (rendering) return Render(render, p, out, err);
    if (!json) {
      Print(p, out);
      return kExitOk;
    }
    out << nlohmann::json{{"positions", p.positions},
                          {"rpm", p.rpm},
                          {"rpm_changed", p.rpm_changed},
                          {"step_time_us", p.step_time_us},
                          {"pulse_width_us", p.pulse_width_us},
                          {"pulses_per_image", p.pulses_per_image},
                          {"pulse_spacing_us", p.pulse_spacing_us},
                          {"pulse_rate_hz", p.pulse_rate_hz},
                          {"skip", p.skip},
                          {"duration_s", p.duration_s},
                          {"position", p.position},
                          {"first_pulse_us", p.first_pulse_us},
                          {"worst_angle_error_deg", p.worst_angle_error_deg},
                          {"note", p.note}}
               .dump()
        << "\n";
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp tool: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  } catch (const toolcam::StrobeError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitCannotPlan;
  } catch (const toolcam::ToolError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitCannotPlan;
  }
}

}  // namespace mlp::host
