#include "mlp/calib/board_views.h"

#include "mlp/base/json_fields.h"
#include "mlp/calib/capture_io.h"
#include "mlp/probe_fw/frame_io.h"
#include "mlp/probe_fw/stripe_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "board_json.h"

namespace mlp::calib {
namespace {

namespace jf = base::json_fields;
namespace fs = std::filesystem;
constexpr const char* kFormat = "mlprobe-board-views/1";
constexpr int kMaxViews = 1000;

GrayImage LoadLed(const std::string& dir,
                  const probe_fw::CaptureManifest& m,
                  int width,
                  int height) {
  for (const auto& e : m.frames) {
    if (e.laser_column >= 0) continue;
    if (e.aoi.x0 != 0 || e.aoi.y0 != 0 || (width > 0 && e.aoi.width != width) ||
        (height > 0 && e.aoi.height != height)) {
      std::ostringstream msg;
      msg << dir << ": the LED frame covers " << e.aoi.width << " x " << e.aoi.height << " px at ("
          << e.aoi.x0 << ", " << e.aoi.y0 << "); calibration needs the whole sensor"
          << (width > 0 ? " (" + std::to_string(width) + " x " + std::to_string(height) + ")" : "")
          << ": render or capture with --aoi full";
      throw CaptureIoError(msg.str());
    }
    probe_fw::Frame f;
    f.aoi = e.aoi;
    probe_fw::ReadImage(dir + "/" + e.file, &f, e.channels, e.raw);
    if (f.aoi.width != e.aoi.width || f.aoi.height != e.aoi.height)
      throw CaptureIoError(dir + "/" + e.file + ": the image's size differs from frames.json");
    return {f.aoi.width, f.aoi.height, e.bit_depth, std::move(f.pixels)};
  }
  throw CaptureIoError(dir + ": the capture has no LED frame (the board's corners are on it)");
}

BoardView LoadView(const std::string& dir,
                   int index,
                   bool with_stripes,
                   int width,
                   int height,
                   std::string* serial) {
  const probe_fw::CaptureManifest m = probe_fw::ReadCaptureManifest(dir);
  if (serial->empty()) *serial = m.meta.probe_serial;
  if (m.meta.probe_serial != *serial)
    throw CaptureIoError(dir + ": frames of probe " + m.meta.probe_serial + ", the others are of " +
                         *serial);
  BoardView v{dir, m.meta.capture_id, LoadLed(dir, m, width, height), {}};
  if (!with_stripes) return v;
  const std::string path = dir + "/stripes.json";
  if (!fs::exists(path))
    throw CaptureIoError(path + " is missing: run `mlp-fw stripes --frames " + dir + " --out " +
                         path + "`");
  const probe_fw::StripeFile s = probe_fw::LoadStripeFile(path);
  if (s.probe_serial != *serial || s.capture_id != m.meta.capture_id)
    throw CaptureIoError(path + ": stripes of probe " + s.probe_serial + " capture " +
                         s.capture_id + ", the frames are " + *serial + " " + m.meta.capture_id);
  for (const auto& p : s.points) v.stripes.push_back({index, p.x_px, double(p.y_px), p.column});
  return v;
}

}  // namespace

BoardViews LoadBoardViews(const std::string& manifest_path,
                          bool with_stripes,
                          int sensor_width_px,
                          int sensor_height_px) {
  const jf::json j =
      jf::ParseDocument<CaptureIoError>(ReadTextFile(manifest_path), kFormat, manifest_path);
  BoardViews out;
  out.board = ParseBoard(j, manifest_path);
  if (!j.contains("views") || !j.at("views").is_array() || j.at("views").empty() ||
      j.at("views").size() > kMaxViews)
    throw CaptureIoError(manifest_path + ": views must be a list of 1 to 1000 capture folders");
  const fs::path base = fs::path(manifest_path).parent_path();
  for (size_t i = 0; i < j.at("views").size(); ++i) {
    const auto& e = j.at("views")[i];
    if (!e.is_string())
      throw CaptureIoError(manifest_path + ": views[" + std::to_string(i) + "] must be a folder");
    const std::string dir = (base / e.get<std::string>()).string();
    // A frame or stripe file that is wrong throws its own input error (base::InputError).
    out.views.push_back(LoadView(dir, static_cast<int>(i), with_stripes, sensor_width_px,
                                 sensor_height_px, &out.probe_serial));
    const GrayImage& first = out.views.front().led;
    if (out.views.back().led.width != first.width || out.views.back().led.height != first.height)
      throw CaptureIoError(dir + ": its LED frame differs in size from the first view's");
  }
  return out;
}

}  // namespace mlp::calib
