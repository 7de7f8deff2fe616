#include "mlp/calib/camera_json.h"

#include "mlp/base/json_fields.h"

#include <map>

namespace mlp::calib {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::ordered_json;

Intrinsics ParseIntrinsics(const nlohmann::json& doc, const char* key, const std::string& where) {
  const nlohmann::json& j = jf::Object<CameraCalibError>(doc, key, where);
  const std::string w = where + "." + key;
  Intrinsics k;
  k.fx_px = jf::Number<CameraCalibError>(j, "fx_px", w);
  k.fy_px = jf::Number<CameraCalibError>(j, "fy_px", w);
  k.cx_px = jf::Number<CameraCalibError>(j, "cx_px", w);
  k.cy_px = jf::Number<CameraCalibError>(j, "cy_px", w);
  k.k1 = jf::Number<CameraCalibError>(j, "k1", w);
  k.k2 = jf::Number<CameraCalibError>(j, "k2", w);
  k.p1 = jf::Number<CameraCalibError>(j, "p1", w);
  k.p2 = jf::Number<CameraCalibError>(j, "p2", w);
  k.k3 = jf::Number<CameraCalibError>(j, "k3", w);
  return k;
}

}  // namespace

json IntrinsicsJson(const Intrinsics& k) {
  return {{"fx_px", k.fx_px}, {"fy_px", k.fy_px}, {"cx_px", k.cx_px},
          {"cy_px", k.cy_px}, {"k1", k.k1},       {"k2", k.k2},
          {"p1", k.p1},       {"p2", k.p2},       {"k3", k.k3}};
}

json BoardViewsJson(const BoardViews& v, const CameraCalibration& c) {
  json views = json::array();
  std::map<int, double> rms;
  for (size_t k = 0; k < c.views_used.size(); ++k) rms[c.views_used[k]] = c.view_rms_px[k];
  for (size_t i = 0; i < v.views.size(); ++i) {
    const auto it = rms.find(static_cast<int>(i));
    json e = {{"capture_id", v.views[i].capture_id}, {"dir", v.views[i].dir}};
    if (it != rms.end())
      e["rms_px"] = it->second;
    else
      e["skipped"] = "no complete board found";
    views.push_back(e);
  }
  return views;
}

json CameraFileJson(const BoardViews& v, const CameraCalibration& c) {
  json j;
  j["format"] = kCameraFileFormat;
  j["probe_serial"] = v.probe_serial;
  j["board"] = {{"inner_cols", v.board.inner_cols},
                {"inner_rows", v.board.inner_rows},
                {"square_mm", v.board.square_mm}};
  const int width = v.views.empty() ? 0 : v.views.front().led.width;
  const int height = v.views.empty() ? 0 : v.views.front().led.height;
  j["image_size_px"] = {width, height};
  j["intrinsics"] = IntrinsicsJson(c.intrinsics);
  j["std_dev"] = IntrinsicsJson(c.std_dev);
  j["rms_reprojection_px"] = c.rms_reprojection_px;
  j["views"] = BoardViewsJson(v, c);
  return j;
}

CameraFile ParseCameraFile(const std::string& text, const std::string& source) {
  const nlohmann::json j = jf::ParseDocument<CameraCalibError>(text, kCameraFileFormat, source);
  CameraFile f;
  f.probe_serial = jf::Text<CameraCalibError>(j, "probe_serial", source);
  const auto& size = j.contains("image_size_px") ? j.at("image_size_px") : nlohmann::json();
  if (!size.is_array() || size.size() != 2 || !size[0].is_number_integer() ||
      !size[1].is_number_integer() || size[0].get<int>() <= 0 || size[1].get<int>() <= 0)
    throw CameraCalibError(source + ".image_size_px must be [width, height] in whole pixels");
  f.width_px = size[0].get<int>();
  f.height_px = size[1].get<int>();
  f.intrinsics = ParseIntrinsics(j, "intrinsics", source);
  f.std_dev = ParseIntrinsics(j, "std_dev", source);
  if (!(f.intrinsics.fx_px > 0) || !(f.intrinsics.fy_px > 0))
    throw CameraCalibError(source + ".intrinsics: the focal lengths must be positive");
  f.rms_reprojection_px = jf::Number<CameraCalibError>(j, "rms_reprojection_px", source);
  return f;
}

}  // namespace mlp::calib
