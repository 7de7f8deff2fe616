#include "mlp/toolcam/tool_images.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"

#include <algorithm>
#include <cmath>

#include "camera_json.h"
#include <nlohmann/json.hpp>

namespace mlp::toolcam {
namespace {

namespace jf = base::json_fields;
constexpr const char* kFormat = "mlprobe-tool-images/1";

ToolCameraModel ParseCamera(const jf::json& c, bool* calibrated) {
  ToolCameraModel m;
  m.width_px = jf::Integer<ToolInputError>(c, "width_px", "camera");
  m.height_px = jf::Integer<ToolInputError>(c, "height_px", "camera");
  ReadLensJson(c, "camera", &m);
  // The lens' scale (nominal, or calibrated with the rest); the axis and tip when calibrated.
  m.mm_per_px = jf::Number<ToolInputError>(c, "mm_per_px", "camera");
  *calibrated = c.contains("axis_u_px") && c.contains("tip_v_px");
  if (*calibrated) {
    m.axis_u_px = jf::Number<ToolInputError>(c, "axis_u_px", "camera");
    m.tip_v_px = jf::Number<ToolInputError>(c, "tip_v_px", "camera");
    m.roll_deg = jf::NumberOr<ToolInputError>(c, "roll_deg", 0.0, "camera");
    m.pitch_deg = jf::NumberOr<ToolInputError>(c, "pitch_deg", 0.0, "camera");
  }
  return m;
}

// One image's entry: its file; its strobe position, its measured angle (or its time since the
// index pulse), or both; its own pulse. What an entry lacks is marked NaN / -1 for
// CheckImageEntries.
void ReadImageEntry(const jf::json& e, double rad_per_us, ToolImages* im) {
  im->files.push_back(jf::Text<ToolInputError>(e, "file", "image"));
  im->position.push_back(
      e.contains("position") ? jf::Integer<ToolInputError>(e, "position", "image") : -1);
  double deg = std::nan("");
  if (e.contains("angle_deg") && e.contains("time_us"))
    throw ToolInputError("image " + im->files.back() + ": angle_deg or time_us, not both");
  if (e.contains("angle_deg")) deg = jf::Number<ToolInputError>(e, "angle_deg", "image");
  if (e.contains("time_us"))
    deg = jf::Number<ToolInputError>(e, "time_us", "image") * rad_per_us * base::kDegPerRad;
  im->angle_deg.push_back(std::isfinite(deg) ? deg - 360.0 * std::floor(deg / 360.0) : deg);
  im->image_blur_rad.push_back(e.contains("pulse_width_us")
                                   ? jf::Number<ToolInputError>(e, "pulse_width_us", "image") *
                                         rad_per_us
                                   : im->blur_rad);
}

// Every image measured or none; a measured angle gives the position when it has none, and
// must lie within a position of the one it has (the encoder and the plan agree).
void CheckImageEntries(const std::string& where, ToolImages* im) {
  const auto measured = static_cast<size_t>(std::count_if(
      im->angle_deg.begin(), im->angle_deg.end(), [](double a) { return std::isfinite(a); }));
  if (measured != 0 && measured != im->angle_deg.size())
    throw ToolInputError(where + ": angle_deg (or time_us) on every image or on none");
  const bool pulses = std::any_of(im->image_blur_rad.begin(), im->image_blur_rad.end(),
                                  [&](double b) { return b != im->blur_rad; });
  for (const double b : im->image_blur_rad)
    if (!(b >= 0 && b < 0.5))
      throw ToolInputError(where + ": an image's pulse_width_us is out of range");
  if (!pulses) im->image_blur_rad.clear();
  const double step_deg = im->positions > 0 ? 360.0 / im->positions : 0.0;
  for (size_t i = 0; i < im->position.size(); ++i) {
    if (measured == 0) {
      if (im->position[i] < 0)
        throw ToolInputError(where + ": image " + im->files[i] + " has no position nor angle");
      continue;
    }
    const double a = im->angle_deg[i];
    const int nearest =
        step_deg > 0 ? static_cast<int>(std::lround(a / step_deg)) % im->positions : 0;
    if (im->position[i] < 0) im->position[i] = nearest;
    if (std::abs(base::WrapDeg(a - im->position[i] * step_deg)) > step_deg)
      throw ToolInputError(where + ": image " + im->files[i] + " measured at " + std::to_string(a) +
                           " deg, more than a position from its position " +
                           std::to_string(im->position[i]));
  }
  if (measured == 0) im->angle_deg.clear();
}

}  // namespace

ToolImages ParseToolImages(const std::string& text, const std::string& where) {
  const jf::json j = jf::ParseDocument<ToolInputError>(text, kFormat, where);
  ToolImages im;
  im.camera = ParseCamera(jf::Object<ToolInputError>(j, "camera", where), &im.calibrated);
  if (j.contains("spindle")) {
    const auto& s = jf::Object<ToolInputError>(j, "spindle", where);
    im.shift.y_mm = jf::NumberOr<ToolInputError>(s, "y_mm", 0.0, "spindle");
    im.shift.z_mm = jf::NumberOr<ToolInputError>(s, "z_mm", 0.0, "spindle");
    if (s.contains("direction")) {
      const std::string d = jf::Text<ToolInputError>(s, "direction", "spindle");
      if (d != "M3" && d != "M4")
        throw ToolInputError(where + ": spindle.direction must be M3 or M4");
      im.m4 = d == "M4";
    }
  }
  const auto& strobe = jf::Object<ToolInputError>(j, "strobe", where);
  im.positions = jf::Integer<ToolInputError>(strobe, "positions", "strobe");
  const double rpm = jf::Number<ToolInputError>(strobe, "rpm", "strobe");
  if (!(rpm >= 0 && rpm <= 100000))
    throw ToolInputError(where + ": strobe.rpm must be in [0, 1e5]");
  const double rad_per_us = rpm / 60 * 2 * base::kPi * 1e-6;
  im.blur_rad = jf::NumberOr<ToolInputError>(strobe, "pulse_width_us", 0.0, "strobe") * rad_per_us;
  if (!j.contains("images") || !j.at("images").is_array())
    throw ToolInputError(where + ": images must list the images");
  for (const auto& e : j.at("images")) ReadImageEntry(e, rad_per_us, &im);
  CheckImageEntries(where, &im);
  // The measurement counts the turn clockwise seen from the spindle (M3's way): under M4 the
  // strobe's position p is the turn's N - p (a position out of range is left to be refused),
  // a measured angle a the turn's 360 - a.
  if (im.m4) {
    for (int& p : im.position)
      if (p > 0 && p < im.positions) p = im.positions - p;
    for (double& a : im.angle_deg) a = a > 0 ? 360.0 - a : 0.0;
  }
  return im;
}

std::string ToolImagesJson(const ToolCameraModel& c,
                           const StrobePlan& plan,
                           const SpindleShift& shift,
                           const std::vector<std::string>& files,
                           const std::vector<int>& position) {
  nlohmann::ordered_json images = nlohmann::ordered_json::array();
  for (size_t i = 0; i < files.size(); ++i)
    images.push_back({{"file", files[i]}, {"position", position.at(i)}});
  const nlohmann::ordered_json manifest = {
      {"format", kFormat},
      {"camera", CameraJson(c)},
      {"strobe",
       {{"rpm", plan.rpm}, {"positions", plan.positions}, {"pulse_width_us", plan.pulse_width_us}}},
      {"spindle", {{"y_mm", shift.y_mm}, {"z_mm", shift.z_mm}, {"direction", "M3"}}},
      {"images", images}};
  return manifest.dump(1) + "\n";
}

}  // namespace mlp::toolcam
