#include "mlp/toolcam/tool_images_io.h"

#include "mlp/base/files.h"
#include "mlp/toolcam/pin_calibration.h"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

namespace mlp::toolcam {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void Refuse(std::string what, const std::string& why) {
  what += why;
  throw ToolInputError(what);
}

// A manifest lists a few hundred images at most; 1 MiB is thousands.
constexpr std::size_t kMaxManifestBytes = 1 << 20;

std::uint32_t BigEndian32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t k = 0; k < 4; ++k) v = (v << 8) | static_cast<std::uint8_t>(b[at + k]);
  return v;
}
std::int32_t LittleEndian32(const std::string& b, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t k = 4; k-- > 0;) v = (v << 8) | static_cast<std::uint8_t>(b[at + k]);
  return static_cast<std::int32_t>(v);
}

// An image's width and height from its header, before anything is decoded: a 875 KB PNG may
// declare 30000 x 30000 pixels (855 MB once decoded). Written by hand because OpenCV 4.6 has no
// header-only read (cv::imread decodes whole). PGM (what the tool camera writes): "P5", then
// width, height and maxval as decimal text between white space and # comments (netpbm's
// pgm(5)); PNG: the IHDR chunk follows the 8-byte signature (ISO/IEC 15948, 11.2.2); BMP:
// BITMAPINFOHEADER's width and height (negative: top-down). Other formats are refused: the tool
// images are lossless (a JPEG's 8 x 8 blocks move an edge by a sub-pixel amount that nothing can
// tell from a real one).
bool PgmSize(const std::string& b, std::int64_t* width, std::int64_t* height) {
  std::size_t at = 2;
  const auto number = [&](std::int64_t* v) {
    for (;;) {  // white space and comments before each number
      while (at < b.size() && std::isspace(static_cast<unsigned char>(b[at]))) ++at;
      if (at < b.size() && b[at] == '#') {
        while (at < b.size() && b[at] != '\n') ++at;
        continue;
      }
      break;
    }
    const std::size_t first = at;
    *v = 0;
    while (at < b.size() && at - first < 9 && std::isdigit(static_cast<unsigned char>(b[at])))
      *v = 10 * *v + (b[at++] - '0');
    return at > first;
  };
  return number(width) && number(height);
}

bool HeaderSize(const std::string& b, std::int64_t* width, std::int64_t* height) {
  if (b.size() >= 3 && b.compare(0, 2, "P5") == 0) return PgmSize(b, width, height);
  static const std::string kPng("\x89PNG\r\n\x1a\n", 8);
  if (b.size() >= 24 && b.compare(0, 8, kPng) == 0 && b.compare(12, 4, "IHDR") == 0) {
    *width = BigEndian32(b, 16), *height = BigEndian32(b, 20);
    return true;
  }
  if (b.size() >= 26 && b.compare(0, 2, "BM") == 0) {
    *width = LittleEndian32(b, 18), *height = std::abs(std::int64_t{LittleEndian32(b, 22)});
    return true;
  }
  return false;
}

// One listed image, its size checked from its header before it is decoded.
std::vector<std::uint8_t> ReadImage(const std::string& file, const ToolCameraModel& camera) {
  const std::string size =
      std::to_string(camera.width_px) + " x " + std::to_string(camera.height_px);
  // Larger than any PGM, PNG or BMP of that size can be (16-bit RGBA, 8 bytes a pixel, and
  // headers).
  const std::size_t max_bytes =
      8 * static_cast<std::size_t>(camera.width_px) * static_cast<std::size_t>(camera.height_px) +
      (1 << 20);
  const std::string bytes = base::ReadFileAs<ToolInputError>(file, "tool images: ", max_bytes);
  std::int64_t w = 0, h = 0;
  if (!HeaderSize(bytes, &w, &h))
    throw ToolInputError(file + " is not a PGM, PNG or BMP image (tool images are lossless)");
  if (w != camera.width_px || h != camera.height_px)
    throw ToolInputError(file + " declares " + std::to_string(w) + " x " + std::to_string(h) +
                         " pixels, the manifest " + size + ": not decoded");
  const cv::Mat g = cv::imdecode(
      cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, const_cast<char*>(bytes.data())),
      cv::IMREAD_GRAYSCALE);
  if (g.empty() || g.cols != camera.width_px || g.rows != camera.height_px)
    throw ToolInputError("cannot read " + file + " as a " + size + " grey image");
  return {g.begin<std::uint8_t>(), g.end<std::uint8_t>()};
}

}  // namespace

ToolImageSeries ReadToolImageSeries(const std::string& dir) {
  const std::string manifest = (fs::path(dir) / "images.json").string();
  std::error_code ec;
  // Regular files only: a FIFO or a device named so would block the reader or never end.
  if (!fs::is_regular_file(manifest, ec)) throw ToolInputError(manifest + " is not a regular file");
  const fs::path folder = fs::canonical(dir, ec);
  ToolImageSeries s;
  static_cast<ToolImages&>(s) = ParseToolImages(
      base::ReadFileAs<ToolInputError>(manifest, "tool images: ", kMaxManifestBytes), manifest);
  const std::int64_t per_image = std::int64_t{s.camera.width_px} * std::int64_t{s.camera.height_px};
  if (per_image * static_cast<std::int64_t>(s.files.size()) > kMaxSeriesPixels)
    throw ToolInputError(manifest + ": more than " + std::to_string(kMaxSeriesPixels) +
                         " pixels of images");
  for (const std::string& name : s.files) {
    if (name.empty() || name.front() == '.' || name.find('/') != std::string::npos ||
        name.find('\\') != std::string::npos)
      Refuse(manifest, ": \"" + name + "\" is not a plain file name in the manifest's folder");
    const std::string file = (fs::path(dir) / name).string();
    if (!fs::is_regular_file(file, ec) || fs::canonical(file, ec).parent_path() != folder)
      Refuse(file, " is not a regular file in " + dir);
    s.pixels.push_back(ReadImage(file, s.camera));
  }
  return s;
}

ToolCameraModel ToolCameraFor(const ToolImageSeries& series,
                              const std::string& calibration_json,
                              const std::string& where,
                              double length_mm,
                              double pitch_warn_deg,
                              std::vector<std::string>* warnings) {
  if (calibration_json.empty()) {
    if (!series.calibrated)
      throw ToolInputError(
          "images.json holds no camera calibration: give the camera's (mlp tool calibrate)");
    return series.camera;
  }
  ToolCameraModel base = series.camera;
  const PinCalibration cal = ParseCameraCalibration(calibration_json, &base, where);
  if (base.width_px != series.camera.width_px || base.height_px != series.camera.height_px)
    throw ToolInputError(where + " is for " + std::to_string(base.width_px) + " x " +
                         std::to_string(base.height_px) + " images, not these");
  if (std::abs(cal.pitch_deg) > pitch_warn_deg) {
    std::ostringstream w;
    w << std::fixed << std::setprecision(3) << "the camera is pitched " << cal.pitch_deg
      << " deg about y: measured through it, but realign the camera (under " << pitch_warn_deg
      << " deg)";
    warnings->push_back(w.str());
  }
  return cal.CameraFor(base, length_mm, series.shift.y_mm, series.shift.z_mm);
}

namespace {

nlohmann::json ViewJson(const FluteView& v) {
  nlohmann::json findings = nlohmann::json::array();
  for (const auto& d : v.findings) {
    nlohmann::json j = {{"kind", d.buildup ? "build-up" : "wear"},
                        {"on", d.corner   ? "corner"
                               : d.on_end ? "end"
                                          : "flank"},
                        {"h_mm", d.h_mm},
                        {"length_mm", d.length_mm},
                        {"max_mm", d.max_mm},
                        {"area_mm2", d.area_mm2}};
    if (d.on_end) j["y_mm"] = d.y_mm;
    findings.push_back(j);
  }
  return {{"side", v.side > 0 ? "+y" : "-y"},
          {"image", v.frame},
          {"principal_image", v.principal},
          {"end_image", v.end_frame == -2   ? nlohmann::json(v.frame)
                        : v.end_frame == -1 ? nlohmann::json(nullptr)
                                            : nlohmann::json(v.end_frame)},
          {"angle_deg", v.angle_deg},
          {"radius_mm", v.radius_mm},
          {"tip_h_mm", v.tip_h_mm},
          {"rms_mm", v.rms_mm},
          {"radius_u_mm", v.radius_u_mm},
          {"tip_u_mm", v.tip_u_mm},
          {"points", v.points},
          {"removed", v.removed},
          {"findings", findings}};
}

}  // namespace

nlohmann::json ToolMeasurementJson(const ToolDescription& tool, const ToolMeasurement& m) {
  nlohmann::json flutes = nlohmann::json::array();
  double mean_radius = 0;
  for (const auto& f : m.flutes) mean_radius += f.radius_mm / static_cast<double>(m.flutes.size());
  for (const auto& f : m.flutes) {
    nlohmann::json views = nlohmann::json::array({ViewJson(f.plus)});
    if (f.minus) views.push_back(ViewJson(*f.minus));
    flutes.push_back({{"edge", f.edge + 1},
                      {"angle_deg", f.angle_deg},
                      {"radius_mm", f.radius_mm},
                      {"radius_u_mm", f.radius_u_mm},
                      {"runout_mm", f.radius_mm - mean_radius},
                      {"tip_h_mm", f.tip_h_mm},
                      {"tip_u_mm", f.tip_u_mm},
                      {"views", views}});
    if (tool.electrode)
      flutes.back().update(
          {{"radial_wear_mm", f.radial_wear_mm}, {"axial_wear_mm", f.axial_wear_mm}});
  }
  nlohmann::json j = {{"tool", tool.id},
                      {"radius_mm", m.radius_mm},
                      {"diameter_mm", 2 * m.radius_mm},
                      {"length_mm", tool.length_mm - m.tip_h_mm},
                      {"runout_mm", m.runout_mm},
                      {"eccentricity_mm", m.eccentricity_mm},
                      {"both_flanks", m.both_flanks},
                      {"worst_finding_mm", m.worst_finding_mm},
                      {"wear_limit_mm", tool.wear_limit_mm},
                      {"flutes", flutes}};
  if (m.both_flanks) j["axis_offset_mm"] = m.axis_offset_mm;
  if (tool.electrode)
    j.update({{"worst_wear_mm", m.worst_wear_mm}, {"half_turn_ambiguous", m.half_turn_ambiguous}});
  return j;
}

nlohmann::json ToolIn3dJson(const ToolDescription& tool, const ToolIn3d& t) {
  nlohmann::json edges = nlohmann::json::array();
  for (size_t k = 0; k < t.edge_mm.size(); ++k)
    edges.push_back({{"flute", k + 1},
                     {"b_flute", t.b_flute[k] + 1},
                     {"radius_mm", t.radius_mm[k]},
                     {"radius_a_less_b_mm", t.radius_disagreement_mm[k]},
                     {"at_position_0_mm", {t.edge_mm[k].x(), t.edge_mm[k].y(), t.edge_mm[k].z()}}});
  return {{"a", ToolMeasurementJson(tool, t.a)},
          {"b", ToolMeasurementJson(tool, t.b)},
          {"two_views",
           {{"view_deg", t.view_deg},
            {"view_rms_deg", t.view_rms_deg},
            {"depth_gain", t.depth_gain},
            {"axis_offset_mm", {t.axis_offset_mm.x(), t.axis_offset_mm.y()}},
            {"tip_h_mm", t.tip_h_mm},
            {"length_mm", tool.length_mm - t.tip_h_mm},
            {"tip_a_less_b_mm", t.tip_disagreement_mm},
            {"edges", edges}}}};
}

}  // namespace mlp::toolcam
