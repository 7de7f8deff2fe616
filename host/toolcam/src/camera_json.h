#pragma once
// The tool camera's model as JSON, as the truth file and the image manifest both write it
// (not installed).

#include "mlp/toolcam/tool_camera.h"

#include <nlohmann/json.hpp>

namespace mlp::toolcam {

inline nlohmann::ordered_json CameraJson(const ToolCameraModel& c) {
  return {{"width_px", c.width_px},   {"height_px", c.height_px},
          {"mm_per_px", c.mm_per_px}, {"axis_u_px", c.axis_u_px},
          {"tip_v_px", c.tip_v_px},   {"distortion_k1", c.distortion_k1},
          {"roll_deg", c.roll_deg},   {"pitch_deg", c.pitch_deg}};
}

}  // namespace mlp::toolcam
