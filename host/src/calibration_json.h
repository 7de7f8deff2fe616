#pragma once
// JSON of calibration results shared by the `mlp calibrate` sub-commands (internal to
// mlp_host_calibrate).

#include "mlp/calib/camera_calib.h"

#include <nlohmann/json.hpp>

namespace mlp::host {

inline nlohmann::ordered_json IntrinsicsJson(const calib::Intrinsics& k) {
  return {{"fx_px", k.fx_px}, {"fy_px", k.fy_px}, {"cx_px", k.cx_px},
          {"cy_px", k.cy_px}, {"k1", k.k1},       {"k2", k.k2},
          {"p1", k.p1},       {"p2", k.p2},       {"k3", k.k3}};
}

}  // namespace mlp::host
