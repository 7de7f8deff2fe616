// `mlp tool measure` and `mlp tool calibrate`: images (DIR/images.json and the images it
// lists) measured against a tool description or a calibration pin; the camera's calibration
// written and read; the measured tool into a LinuxCNC tool table (atomically, bounded, logged).

#include "mlp/host/cli.h"
#include "mlp/nc/tool_table.h"
#include "mlp/nc/tool_table_update.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/pin_calibration.h"
#include "mlp/toolcam/tool_images.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "tool_commands.h"
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::host::tool {
namespace {

namespace fs = std::filesystem;

constexpr int kExitRefused = 4;  // measured, but the tool table was not changed (the reason)
// A pitch beyond this is corrected in the model but a person is told to realign the camera:
// the far side of a D20 tool then leaves a 0.2 mm depth of field's middle by over 0.1 mm.
constexpr double kPitchWarnDeg = 0.5;

// The measurement stands; a change it would make was refused (the reason).
class RefusedError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Images : toolcam::ToolImages {
  std::vector<std::vector<std::uint8_t>> pixels;
};

// DIR/images.json (`mlprobe-tool-images/1`, read by toolcam) and the images it lists (any
// format OpenCV reads).
Images ReadImages(const std::string& dir) {
  const std::string manifest = (fs::path(dir) / "images.json").string();
  Images im;
  static_cast<toolcam::ToolImages&>(im) =
      toolcam::ParseToolImages(ReadInputFile(manifest), manifest);
  for (const std::string& name : im.files) {
    const std::string file = (fs::path(dir) / name).string();
    const cv::Mat g = cv::imread(file, cv::IMREAD_GRAYSCALE);
    if (g.empty() || g.cols != im.camera.width_px || g.rows != im.camera.height_px)
      throw UsageError("cannot read " + file + " as a " + std::to_string(im.camera.width_px) +
                       " x " + std::to_string(im.camera.height_px) + " grey image");
    im.pixels.emplace_back(g.begin<std::uint8_t>(), g.end<std::uint8_t>());
  }
  return im;
}

// The camera for the tool in these images: the calibration file's (with the spindle's shift
// from the manifest) or else the manifest's own.
toolcam::ToolCameraModel CameraFor(const Images& im,
                                   const std::string& calibration_file,
                                   double tool_length_mm,
                                   std::vector<std::string>* warnings) {
  if (calibration_file.empty()) {
    if (!im.calibrated)
      throw UsageError(
          "images.json holds no camera calibration: give --camera (mlp tool calibrate)");
    return im.camera;
  }
  toolcam::ToolCameraModel base = im.camera;
  const toolcam::PinCalibration cal =
      toolcam::ParseCameraCalibration(ReadInputFile(calibration_file), &base, calibration_file);
  if (base.width_px != im.camera.width_px || base.height_px != im.camera.height_px)
    throw UsageError(calibration_file + " is for " + std::to_string(base.width_px) + " x " +
                     std::to_string(base.height_px) + " images, not these");
  if (std::abs(cal.pitch_deg) > kPitchWarnDeg) {
    std::ostringstream w;
    w << std::fixed << std::setprecision(3) << "the camera is pitched " << cal.pitch_deg
      << " deg about y: measured through it, but realign the camera (under " << kPitchWarnDeg
      << " deg)";
    warnings->push_back(w.str());
  }
  return cal.CameraFor(base, tool_length_mm, im.shift.y_mm, im.shift.z_mm);
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
void WriteOverlay(const std::string& path,
                  const std::vector<std::vector<std::uint8_t>>& images,
                  const toolcam::ToolCameraModel& camera,
                  const toolcam::ToolMeasurement& m) {
  std::vector<cv::Mat> tiles;
  const cv::Scalar kColour[] = {{0, 0, 0}, {0, 220, 255}, {255, 80, 0}, {0, 0, 255}};
  for (size_t k = 0; k < m.flutes.size(); ++k) {
    const auto& f = m.flutes[k];
    const auto& px = images[static_cast<size_t>(f.frame)];
    cv::Mat grey(camera.height_px, camera.width_px, CV_8UC1, const_cast<std::uint8_t*>(px.data()));
    cv::Mat tile;
    cv::cvtColor(grey, tile, cv::COLOR_GRAY2BGR);
    std::vector<cv::Point> model;
    for (const auto& p : f.model_yh) model.push_back(ToPixel(p, camera));
    cv::polylines(tile, model, false, cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
    for (size_t i = 0; i < f.points_yh.size(); ++i)
      if (f.point_kind[i] != toolcam::FluteMeasurement::kUsed)
        cv::circle(tile, ToPixel(f.points_yh[i], camera), 2, kColour[f.point_kind[i]], cv::FILLED);
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

// The measured length (Z) and diameter (D) into tool `number` of a LinuxCNC tool table,
// through nc's one writer (checked, whole or not at all, logged beside the table). Wear or
// build-up found refuses unless accepted: a tool to look at is not a tool to set.
nc::ToolTableUpdateResult UpdateToolTable(const std::string& file,
                                          int number,
                                          double max_change_mm,
                                          bool accept_findings,
                                          const toolcam::ToolDescription& tool,
                                          const toolcam::ToolMeasurement& m,
                                          const std::string& images) {
  int findings = 0;
  for (const auto& f : m.flutes) findings += static_cast<int>(f.findings.size());
  if (findings > 0 && !accept_findings)
    throw RefusedError("tool table not changed: " + std::to_string(findings) +
                       " finding(s) of wear or build-up: look at the tool (--accept-findings "
                       "writes it anyway)");
  nc::ToolUpdate update;
  update.tool = number;
  update.tool_id = tool.id;
  update.length_mm = tool.length_mm - m.tip_h_mm;
  update.diameter_mm = 2 * m.radius_mm;
  try {
    return nc::UpdateToolTable(file, {update}, {max_change_mm, max_change_mm}, images);
  } catch (const nc::ToolChangeRefused& e) {  // a refusal, said with the option that sets it
    throw RefusedError(std::string(e.what()) + " (--max-change-mm)");
  }
}

void PrintMeasurement(const toolcam::ToolDescription& tool,
                      const toolcam::ToolMeasurement& m,
                      std::ostream& out) {
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
}

void SaveReference(const std::string& path,
                   const toolcam::ToolDescription& tool,
                   const toolcam::ToolMeasurement& m) {
  WriteOutputFile(path, toolcam::ToJson(toolcam::ReferenceFrom(tool, m)));
}

// --tool-table / --tool-number: the measurement into the table, the change (or the refusal)
// into result["tool_table"]. Returns the exit code: refused or ok.
int WriteToolTable(const Args& f,
                   const toolcam::ToolDescription& tool,
                   const toolcam::ToolMeasurement& m,
                   const std::string& images,
                   nlohmann::json* result,
                   std::ostream& err) {
  const std::string table = f.Text("--tool-table", "");
  const int number = static_cast<int>(f.Number("--tool-number"));
  const double max_change = f.Number("--max-change-mm", 0.5);
  try {
    const nc::ToolTableUpdateResult u =
        UpdateToolTable(table, number, max_change, f.Has("--accept-findings"), tool, m, images);
    const nc::ToolTableChange& c = u.changes.front();
    (*result)["tool_table"] = {{"file", table},
                               {"tool", c.tool},
                               {"length_before_mm", c.length_before_mm},
                               {"length_after_mm", c.length_after_mm},
                               {"diameter_before_mm", c.diameter_before_mm},
                               {"diameter_after_mm", c.diameter_after_mm},
                               {"log", u.log_file}};
    if (!u.log_error.empty()) {
      (*result)["tool_table"]["log_error"] = u.log_error;
      err << "mlp tool: warning: " << u.log_error << "\n";
    }
    return kExitOk;
  } catch (const RefusedError& e) {
    (*result)["tool_table"] = {{"file", table}, {"refused", e.what()}};
    err << "mlp tool: " << e.what() << "\n";
    return kExitRefused;
  }
}

void PrintToolTableChange(const nlohmann::json& t, std::ostream& out) {
  out << std::fixed << std::setprecision(4) << "  tool table " << t["file"].get<std::string>()
      << ": T" << t["tool"].get<int>() << " Z " << t["length_before_mm"].get<double>() << " -> "
      << t["length_after_mm"].get<double>() << " mm, D " << t["diameter_before_mm"].get<double>()
      << " -> " << t["diameter_after_mm"].get<double>() << " mm\n";
}

}  // namespace

int Measure(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--images", "--frames", "--tool", "--camera", "--overlay",
                       "--save-reference", "--tool-table", "--tool-number", "--max-change-mm"},
                      {"--json", "--accept-findings"}});
  const std::string images =
      f.Text("--images", "").empty() ? f.Text("--frames", "") : f.Text("--images", "");
  if (images.empty() || f.Text("--tool", "").empty())
    throw UsageError("mlp tool measure needs --images (or --frames) and --tool");
  if (f.Text("--tool-table", "").empty() != f.Text("--tool-number", "").empty())
    throw UsageError("--tool-table and --tool-number go together");
  const toolcam::ToolDescription tool = toolcam::LoadTool(f.Text("--tool", ""));
  const Images im = ReadImages(images);
  std::vector<std::string> warnings;
  const toolcam::ToolCameraModel camera =
      CameraFor(im, f.Text("--camera", ""), tool.length_mm, &warnings);
  for (const auto& w : warnings) err << "mlp tool: warning: " << w << "\n";
  toolcam::MeasureOptions options;
  options.blur_rad = im.blur_rad;
  const toolcam::ToolMeasurement m =
      toolcam::MeasureTool(im.pixels, im.position, im.positions, tool, camera, options);
  if (!f.Text("--overlay", "").empty()) WriteOverlay(f.Text("--overlay", ""), im.pixels, camera, m);
  if (!f.Text("--save-reference", "").empty())
    SaveReference(f.Text("--save-reference", ""), tool, m);
  nlohmann::json result = MeasurementJson(tool, m);
  result["warnings"] = warnings;
  const int code = f.Text("--tool-table", "").empty()
                       ? kExitOk
                       : WriteToolTable(f, tool, m, images, &result, err);
  if (f.Has("--json")) {
    out << result.dump() << "\n";
    return code;
  }
  PrintMeasurement(tool, m, out);
  if (result.contains("tool_table") && !result["tool_table"].contains("refused"))
    PrintToolTableChange(result["tool_table"], out);
  if (!f.Text("--overlay", "").empty()) out << "  overlay: " << f.Text("--overlay", "") << "\n";
  return code;
}

int Calibrate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--images", "--frames", "--pin", "--out"}, {"--json"}});
  const std::string images =
      f.Text("--images", "").empty() ? f.Text("--frames", "") : f.Text("--images", "");
  if (images.empty() || f.Text("--pin", "").empty() || f.Text("--out", "").empty())
    throw UsageError("mlp tool calibrate needs --images (or --frames), --pin and --out");
  const toolcam::ToolDescription pin = toolcam::LoadTool(f.Text("--pin", ""));
  if (!pin.pin) throw UsageError(f.Text("--pin", "") + " is not a pin (\"kind\": \"pin\")");
  const Images im = ReadImages(images);  // its mm_per_px: the lens' nominal scale
  err << "mlp tool: calibrating from " << im.pixels.size() << " images of " << pin.id << "\n";
  const toolcam::PinCalibration p =
      toolcam::CalibrateWithPin(im.pixels, im.position, im.positions, im.camera, pin);
  WriteOutputFile(f.Text("--out", ""), toolcam::CameraCalibrationJson(p, im.camera, pin.id));
  std::vector<std::string> advice;
  if (p.pitch_measured && std::abs(p.pitch_deg) > kPitchWarnDeg)
    advice.push_back(
        "realign the camera about y (tools are measured through the pitch, but the "
        "far side of a large tool leaves the depth of field)");
  if (!p.pitch_measured) advice.push_back("the pin has no blades: the pitch was not measured");
  if (f.Has("--json")) {
    nlohmann::json j = nlohmann::json::parse(toolcam::CameraCalibrationJson(p, im.camera, pin.id));
    j["file"] = f.Text("--out", "");
    j["advice"] = advice;
    out << j.dump() << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(7) << "camera calibration from " << pin.id << ": "
      << p.mm_per_px << " mm/px\n"
      << std::setprecision(4) << "  roll (about x) " << p.roll_deg << " deg, pitch (about y) "
      << (p.pitch_measured ? std::to_string(p.pitch_deg) + " deg" : std::string("not measured"))
      << "\n  spindle axis at the pin's end: column " << std::setprecision(3) << p.end_u_px
      << ", row " << p.end_v_px << "; gauge point row " << p.gauge_v_px << "\n  flanks over "
      << p.rows << " rows, width rms " << p.width_rms_px << " px";
  if (p.pitch_measured)
    out << "; blades in " << p.blade_images << " images, ends rms " << std::setprecision(2)
        << p.blade_rms_um << " um";
  out << "\n  written to " << f.Text("--out", "") << "\n";
  for (const auto& a : advice) out << "  note: " << a << "\n";
  return kExitOk;
}

}  // namespace mlp::host::tool
