#include "mlp/toolcam/tool_images.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"

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
  m.distortion_k1 = jf::NumberOr<ToolInputError>(c, "distortion_k1", 0.0, "camera");
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
  im.blur_rad = jf::NumberOr<ToolInputError>(strobe, "pulse_width_us", 0.0, "strobe") * 1e-6 *
                jf::Number<ToolInputError>(strobe, "rpm", "strobe") / 60 * 2 * base::kPi;
  if (!j.contains("images") || !j.at("images").is_array())
    throw ToolInputError(where + ": images must list the images");
  for (const auto& e : j.at("images")) {
    im.files.push_back(jf::Text<ToolInputError>(e, "file", "image"));
    im.position.push_back(jf::Integer<ToolInputError>(e, "position", "image"));
  }
  // The measurement counts the turn clockwise seen from the spindle (M3's way): under M4 the
  // strobe's position p is the turn's N - p (a position out of range is left to be refused).
  if (im.m4)
    for (int& p : im.position)
      if (p > 0 && p < im.positions) p = im.positions - p;
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
