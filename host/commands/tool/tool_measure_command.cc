// `mlp tool measure` and `mlp tool calibrate`: images (DIR/images.json and the images it
// lists) measured against a tool description or a calibration pin; the camera's calibration
// written and read. The tool table is the host service's to write (its tool job, through the
// machine's one adapter), not this command's.

#include "mlp/host/cli.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/pin_calibration.h"
#include "mlp/toolcam/tool_images_io.h"

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

// A pitch beyond this is corrected in the model but a person is told to realign the camera:
// the far side of a D20 tool then leaves a 0.2 mm depth of field's middle by over 0.1 mm.
constexpr double kPitchWarnDeg = 0.5;

// Tool frame -> pixel, through the lens' distortion (the measurement's mapping inverted).
cv::Point2d ToPixel(const geometry::Vec2& yh, const toolcam::ToolCameraModel& c) {
  const geometry::Vec2 px = c.Distort(c.PixelFromTool(yh));
  return {px.x(), px.y()};
}

// One view's tile: its image, the fitted model in green, contamination yellow, wear blue,
// build-up red, the figures on top.
cv::Mat ViewTile(const std::vector<std::vector<std::uint8_t>>& images,
                 const toolcam::ToolCameraModel& camera,
                 const toolcam::FluteView& v,
                 const std::string& title) {
  const cv::Scalar kColour[] = {{0, 0, 0}, {0, 220, 255}, {255, 80, 0}, {0, 0, 255}};
  const auto& px = images[static_cast<size_t>(v.frame)];
  cv::Mat grey(camera.height_px, camera.width_px, CV_8UC1, const_cast<std::uint8_t*>(px.data()));
  cv::Mat tile;
  cv::cvtColor(grey, tile, cv::COLOR_GRAY2BGR);
  std::vector<cv::Point> model;
  for (const auto& p : v.model_yh) model.push_back(ToPixel(p, camera));
  cv::polylines(tile, model, false, cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
  for (size_t i = 0; i < v.points_yh.size(); ++i)
    if (v.point_kind[i] != toolcam::FluteView::kUsed)
      cv::circle(tile, ToPixel(v.points_yh[i], camera), 2, kColour[v.point_kind[i]], cv::FILLED);
  std::ostringstream t;
  t.setf(std::ios::fixed);
  t.precision(4);
  t << title << ": r " << v.radius_mm << " mm, tip " << std::showpos << std::setprecision(2)
    << v.tip_h_mm * 1e3 << std::noshowpos << " um, " << v.findings.size() << " finding(s)";
  cv::putText(tile, t.str(), {12, 28}, cv::FONT_HERSHEY_SIMPLEX, 0.7, {0, 0, 160}, 2, cv::LINE_AA);
  return tile;
}

// A series of images and the camera they were taken with.
struct Shown {
  const std::vector<std::vector<std::uint8_t>>& images;
  const toolcam::ToolCameraModel& camera;
};

// The principal images of every flute (both flanks' with the axis in view, or from the other
// side's series), in rows of two.
void WriteOverlay(const std::string& path,
                  const Shown& plus,
                  const Shown& minus,
                  const toolcam::ToolMeasurement& m) {
  std::vector<cv::Mat> tiles;
  for (size_t k = 0; k < m.flutes.size(); ++k) {
    const auto& f = m.flutes[k];
    const std::string name = "flute " + std::to_string(k + 1);
    tiles.push_back(ViewTile(plus.images, plus.camera, f.plus, f.minus ? name + " +y" : name));
    if (f.minus) tiles.push_back(ViewTile(minus.images, minus.camera, *f.minus, name + " -y"));
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

void PrintView(const toolcam::FluteView& v, const std::string& indent, std::ostream& out) {
  for (const auto& d : v.findings) {
    out << std::setprecision(3) << indent << (d.buildup ? "build-up" : "wear");
    if (d.corner)
      out << " at the corner (y " << d.y_mm << " mm, h " << d.h_mm << " mm): ";
    else if (d.on_end)
      out << " on the end at y " << d.y_mm << " mm, h " << d.h_mm << " mm: ";
    else
      out << " at h " << d.h_mm << " mm: ";
    out << std::setprecision(1) << d.max_mm * 1e3 << " um, " << std::setprecision(3) << d.length_mm
        << " mm long, " << std::setprecision(5) << d.area_mm2 << " mm2\n";
  }
}

void PrintMeasurement(const toolcam::ToolDescription& tool,
                      const toolcam::ToolMeasurement& m,
                      std::ostream& out) {
  out << std::fixed << std::setprecision(4) << "tool " << tool.id << ": diameter "
      << 2 * m.radius_mm << " mm, length " << tool.length_mm - m.tip_h_mm << " mm, runout "
      << std::setprecision(1) << m.runout_mm * 1e3 << " um\n";
  if (m.both_flanks)
    out << "  both flanks in view: the spindle axis " << std::showpos << m.axis_offset_mm * 1e3
        << std::noshowpos << " um across from the camera's calibration\n";
  for (size_t k = 0; k < m.flutes.size(); ++k) {
    const auto& f = m.flutes[k];
    out << std::setprecision(4) << "  flute " << k + 1 << ": radius " << f.radius_mm << " mm (u "
        << std::setprecision(2) << f.radius_u_mm * 1e3 << " um), tip " << f.tip_h_mm * 1e3
        << " um (u " << f.tip_u_mm * 1e3 << " um), rms " << f.plus.rms_mm * 1e3 << " um\n";
    PrintView(f.plus, f.minus ? "    +y: " : "    ", out);
    if (f.minus) PrintView(*f.minus, "    -y: ", out);
    if (tool.electrode)
      out << std::setprecision(1) << "    corner " << f.edge + 1 << " worn "
          << f.radial_wear_mm * 1e3 << " um in, " << f.axial_wear_mm * 1e3 << " um up\n";
  }
  if (tool.electrode)
    out << std::setprecision(1) << "  worst corner wear " << m.worst_wear_mm * 1e3
        << " um, the electrode's wear limit " << tool.wear_limit_mm * 1e3
        << " um: " << (m.OverWearLimit(tool) ? "REJECT" : "accept")
        << (m.half_turn_ambiguous
                ? "\n  corners named only up to a half turn: give --start-turn-deg (the chuck's "
                  "angle) or measure against a stored reference\n"
                : "\n");
  if (m.worst_finding_mm > 0)
    out << std::setprecision(1) << "  worst finding " << m.worst_finding_mm * 1e3
        << " um, the tool's wear limit " << tool.wear_limit_mm * 1e3 << " um\n";
}

void SaveReference(const std::string& path,
                   const toolcam::ToolDescription& tool,
                   const toolcam::ToolMeasurement& m) {
  WriteOutputFile(path, toolcam::ToJson(toolcam::ReferenceFrom(tool, m)));
}

void PrintTwoViews(const toolcam::ToolDescription& tool,
                   const toolcam::ToolIn3d& t,
                   const toolcam::SecondView& mount,
                   std::ostream& out) {
  out << std::fixed << std::setprecision(3) << "two views " << t.view_deg
      << " deg apart as the flutes show it (mount " << mount.view_deg << ", rms " << t.view_rms_deg
      << "): depth gain " << t.depth_gain << "\n"
      << std::setprecision(2) << std::showpos << "  spindle axis off the calibrations: x "
      << t.axis_offset_mm.x() * 1e3 << " um (along A's view), y " << t.axis_offset_mm.y() * 1e3
      << " um" << std::noshowpos << "\n  length " << std::setprecision(4)
      << tool.length_mm - t.tip_h_mm << " mm, the cameras' tips " << std::showpos
      << std::setprecision(2) << t.tip_disagreement_mm * 1e3 << std::noshowpos << " um apart\n";
  for (size_t k = 0; k < t.edge_mm.size(); ++k)
    out << std::setprecision(4) << "  flute " << k + 1 << ": radius " << t.radius_mm[k]
        << " mm (A - B " << std::showpos << std::setprecision(2)
        << t.radius_disagreement_mm[k] * 1e3 << std::noshowpos << " um), at position 0 ("
        << std::setprecision(4) << t.edge_mm[k].x() << ", " << t.edge_mm[k].y() << ", "
        << t.edge_mm[k].z() << ") mm\n";
}

// Seed 000 example 7: the same pulses' series from a second camera, its view turned
// --view-deg from the first's (two_views.h).
int MeasureTwoViews(const Args& f,
                    const toolcam::ToolDescription& tool,
                    const toolcam::ToolSeries& a,
                    const toolcam::MeasureOptions& options,
                    std::vector<std::string>* warnings,
                    std::ostream& out,
                    std::ostream& err) {
  if (f.Has("--other-side") || f.Has("--save-reference"))
    throw UsageError("--second-view does not go with --other-side or --save-reference");
  if (!f.Has("--view-deg")) throw UsageError("--second-view needs --view-deg (the mount's angle)");
  const toolcam::SecondView mount{
      f.Number("--view-deg"),
      f.Number("--view-tolerance-deg", toolcam::SecondView{}.tolerance_deg)};
  const toolcam::ToolImageSeries im = toolcam::ReadToolImageSeries(f.Text("--second-view", ""));
  const std::string camera_file = f.Text("--second-camera", "");
  const size_t before = warnings->size();  // the first camera's are printed
  const toolcam::ToolCameraModel camera =
      toolcam::ToolCameraFor(im, camera_file.empty() ? "" : ReadInputFile(camera_file), camera_file,
                             tool.length_mm, kPitchWarnDeg, warnings);
  for (size_t k = before; k < warnings->size(); ++k)
    err << "mlp tool: warning: " << (*warnings)[k] << "\n";
  const toolcam::ToolIn3d t = toolcam::MeasureToolFromTwoViews(
      a, {im.pixels, im.position, im.positions, camera, &im.angle_deg, &im.image_blur_rad}, tool,
      mount, options);
  if (!f.Text("--overlay", "").empty())
    WriteOverlay(f.Text("--overlay", ""), {a.frames, a.camera}, {a.frames, a.camera}, t.a);
  if (f.Has("--json")) {
    nlohmann::json result = toolcam::ToolIn3dJson(tool, t);
    result["warnings"] = *warnings;
    out << result.dump() << "\n";
    return kExitOk;
  }
  out << "camera A:\n";
  PrintMeasurement(tool, t.a, out);
  out << "camera B:\n";
  PrintMeasurement(tool, t.b, out);
  PrintTwoViews(tool, t, mount, out);
  return kExitOk;
}

}  // namespace

int Measure(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--images", "--frames", "--other-side", "--tool", "--camera", "--overlay",
                       "--save-reference", "--start-turn-deg", "--second-view", "--second-camera",
                       "--view-deg", "--view-tolerance-deg", "--ref-height-mm"},
                      {"--json"}});
  const std::string images =
      f.Text("--images", "").empty() ? f.Text("--frames", "") : f.Text("--images", "");
  if (images.empty() || f.Text("--tool", "").empty())
    throw UsageError("mlp tool measure needs --images (or --frames) and --tool");
  const toolcam::ToolDescription tool = toolcam::LoadTool(f.Text("--tool", ""));
  const std::string camera_file = f.Text("--camera", "");
  const std::string camera_text = camera_file.empty() ? "" : ReadInputFile(camera_file);
  std::vector<std::string> warnings;
  const toolcam::ToolImageSeries im = toolcam::ReadToolImageSeries(images);
  const toolcam::ToolCameraModel camera = toolcam::ToolCameraFor(
      im, camera_text, camera_file, tool.length_mm, kPitchWarnDeg, &warnings);
  // A tool wider than the field: its -y side's series, the spindle moved across (its shift in
  // that manifest).
  const std::string other = f.Text("--other-side", "");
  const toolcam::ToolImageSeries im_other =
      other.empty() ? toolcam::ToolImageSeries{} : toolcam::ReadToolImageSeries(other);
  const toolcam::ToolCameraModel camera_other =
      other.empty() ? camera
                    : toolcam::ToolCameraFor(im_other, camera_text, camera_file, tool.length_mm,
                                             kPitchWarnDeg, &warnings);
  for (const auto& w : warnings) err << "mlp tool: warning: " << w << "\n";
  toolcam::MeasureOptions options = toolcam::ForTool(tool);
  options.blur_rad = im.blur_rad;
  if (f.Has("--ref-height-mm")) options.h_ref_mm = f.Number("--ref-height-mm");
  if (f.Has("--start-turn-deg")) {
    options.start_turn_deg = f.Number("--start-turn-deg");
    if (!(std::abs(*options.start_turn_deg) <= 360))
      throw UsageError("--start-turn-deg must be in [-360, 360]");
  }
  const toolcam::ToolSeries series{im.pixels, im.position,   im.positions,
                                   camera,    &im.angle_deg, &im.image_blur_rad};
  if (f.Has("--second-view")) return MeasureTwoViews(f, tool, series, options, &warnings, out, err);
  const toolcam::ToolMeasurement m =
      other.empty() ? toolcam::MeasureTool(series, tool, options)
                    : toolcam::MeasureToolBothSides(
                          series,
                          {im_other.pixels, im_other.position, im_other.positions, camera_other,
                           &im_other.angle_deg, &im_other.image_blur_rad},
                          tool, options);
  if (!f.Text("--overlay", "").empty())
    WriteOverlay(f.Text("--overlay", ""), {im.pixels, camera},
                 other.empty() ? Shown{im.pixels, camera} : Shown{im_other.pixels, camera_other},
                 m);
  if (!f.Text("--save-reference", "").empty())
    SaveReference(f.Text("--save-reference", ""), tool, m);
  if (f.Has("--json")) {
    nlohmann::json result = toolcam::ToolMeasurementJson(tool, m);
    result["warnings"] = warnings;
    out << result.dump() << "\n";
    return kExitOk;
  }
  PrintMeasurement(tool, m, out);
  if (!f.Text("--overlay", "").empty()) out << "  overlay: " << f.Text("--overlay", "") << "\n";
  return kExitOk;
}

int Calibrate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args f(args, {{"--images", "--frames", "--pin", "--out"}, {"--json"}});
  const std::string images =
      f.Text("--images", "").empty() ? f.Text("--frames", "") : f.Text("--images", "");
  if (images.empty() || f.Text("--pin", "").empty() || f.Text("--out", "").empty())
    throw UsageError("mlp tool calibrate needs --images (or --frames), --pin and --out");
  const toolcam::ToolDescription pin = toolcam::LoadTool(f.Text("--pin", ""));
  if (!pin.pin) throw UsageError(f.Text("--pin", "") + " is not a pin (\"kind\": \"pin\")");
  const toolcam::ToolImageSeries im = toolcam::ReadToolImageSeries(images);  // the nominal scale
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
  if (!p.distortion_measured) {
    std::ostringstream why;
    why << "the lens' distortion was not measured (the flanks give k1 to +-" << std::scientific
        << std::setprecision(1) << p.distortion_sigma
        << "): the images.json value is used; show the pin over most of the image's height "
           "in a few dozen images";
    advice.push_back(why.str());
  }
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
      << p.rows << " rows, width rms " << p.width_rms_px << " px\n  lens distortion k1 "
      << std::setprecision(6) << p.distortion_k1
      << (p.distortion_measured ? " (measured)" : " (from images.json)");
  if (p.pitch_measured)
    out << "; blades in " << p.blade_images << " images, ends rms " << std::setprecision(2)
        << p.blade_rms_um << " um";
  out << "\n  written to " << f.Text("--out", "") << "\n";
  for (const auto& a : advice) out << "  note: " << a << "\n";
  return kExitOk;
}

}  // namespace mlp::host::tool
