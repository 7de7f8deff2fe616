#pragma once
// The tool camera's model as JSON, as the truth file and the image manifest both write it
// (not installed).

#include "mlp/base/json_fields.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"

#include <string>

#include <nlohmann/json.hpp>

namespace mlp::toolcam {

// The lens' terms beyond the radial one (a principal point, tangential terms), where set.
inline void AddLensJson(const ToolCameraModel& c, nlohmann::ordered_json* j) {
  if (c.distortion_p1 != 0 || c.distortion_p2 != 0)
    (*j)["distortion_p1"] = c.distortion_p1, (*j)["distortion_p2"] = c.distortion_p2;
  if (c.principal_u_px) (*j)["principal_u_px"] = *c.principal_u_px;
  if (c.principal_v_px) (*j)["principal_v_px"] = *c.principal_v_px;
}

// ... and read back (`what` names the file's part in an error).
template <typename Json>
void ReadLensJson(const Json& j, const std::string& what, ToolCameraModel* c) {
  namespace jf = base::json_fields;
  c->distortion_k1 = jf::NumberOr<ToolInputError>(j, "distortion_k1", 0.0, what);
  c->distortion_p1 = jf::NumberOr<ToolInputError>(j, "distortion_p1", 0.0, what);
  c->distortion_p2 = jf::NumberOr<ToolInputError>(j, "distortion_p2", 0.0, what);
  if (j.contains("principal_u_px") != j.contains("principal_v_px"))
    throw ToolInputError(what + ": principal_u_px and principal_v_px come together");
  if (j.contains("principal_u_px")) {
    c->principal_u_px = jf::Number<ToolInputError>(j, "principal_u_px", what);
    c->principal_v_px = jf::Number<ToolInputError>(j, "principal_v_px", what);
  }
}

inline nlohmann::ordered_json CameraJson(const ToolCameraModel& c) {
  nlohmann::ordered_json j = {{"width_px", c.width_px},   {"height_px", c.height_px},
                              {"mm_per_px", c.mm_per_px}, {"axis_u_px", c.axis_u_px},
                              {"tip_v_px", c.tip_v_px},   {"distortion_k1", c.distortion_k1},
                              {"roll_deg", c.roll_deg},   {"pitch_deg", c.pitch_deg}};
  AddLensJson(c, &j);
  return j;
}

}  // namespace mlp::toolcam
