#include "mlp/calib/hand_eye_json.h"

#include "mlp/base/json_fields.h"

#include <cmath>

namespace mlp::calib {
namespace {

using json = nlohmann::ordered_json;
using base::json_fields::PoseToJson;
using base::json_fields::Vec3ToJson;

json StdDevJson(const HandEyeResult& r) {
  json sd;
  for (size_t k = 0; k < kHandEyeParameters.size(); ++k) {
    const auto i = static_cast<Eigen::Index>(k);
    sd[kHandEyeParameters[k]] = std::sqrt(r.covariance(i, i));
  }
  return sd;
}

json CapturesJson(const HandEyeResult& r) {
  json caps = json::array();
  for (const auto& c : r.captures) {
    caps.push_back({{"id", c.id},
                    {"points", c.points},
                    {"inliers", c.inliers},
                    {"rms_mm", c.rms_mm},
                    {"centre_mcs_mm", Vec3ToJson(c.centre_mcs)}});
  }
  return caps;
}

json SensorJson(const SensorEstimate& e) {
  return {{"scale", Vec3ToJson(e.scale)},
          {"scale_std", Vec3ToJson(e.scale_std)},
          {"incidence_bias_mm", e.incidence_bias_mm},
          {"incidence_bias_std_mm", e.incidence_bias_std_mm},
          {"scale_bias_correlation", e.scale_bias_correlation},
          {"findings", e.findings}};
}

json LeaveOneOutJson(const LeaveOneOut& v) {
  json caps = json::array();
  for (const auto& c : v.captures)
    caps.push_back({{"id", c.id}, {"rms_mm", c.rms_mm}, {"centre_error_mm", c.centre_error_mm}});
  return {{"rms_mm", v.rms_mm}, {"centre_error_rms_mm", v.centre_error_rms_mm}, {"captures", caps}};
}

}  // namespace

json HandEyeResultJson(const HandEyeResult& r) {
  json j;
  j["flange_from_probe"] = PoseToJson(r.flange_from_probe);
  j["std_dev"] = StdDevJson(r);
  j["sphere_centre_mcs_mm"] = Vec3ToJson(r.centre_mcs);
  j["point_rms_mm"] = r.point_rms_mm;
  j["points_used"] = r.points_used;
  j["points_rejected"] = r.points_rejected;
  j["centre_spread_rms_mm"] = r.centre_spread_rms_mm;
  j["centre_spread_max_mm"] = r.centre_spread_max_mm;
  j["centre_mean_offset_mm"] = r.centre_mean_offset_mm;
  j["captures"] = CapturesJson(r);
  if (r.sensor.estimated) j["sensor"] = SensorJson(r.sensor);
  j["leave_one_out"] = LeaveOneOutJson(r.leave_one_out);
  j["warnings"] = r.warnings;
  return j;
}

json RecheckResultJson(const RecheckResult& r) {
  json j;
  j["full_calibration_required"] = r.full_calibration_required;
  j["reason"] = r.reason;
  j["flange_from_probe"] = PoseToJson(r.flange_from_probe);
  j["offset_in_flange_mm"] = Vec3ToJson(r.offset_in_flange_mm);
  j["rotation_in_flange_rad"] = Vec3ToJson(r.rotation_in_flange_rad);
  j["centre_shift_mm"] = Vec3ToJson(r.centre_shift_mm);
  j["residual_before_mm"] = r.residual_before_mm;
  j["residual_after_mm"] = r.residual_after_mm;
  j["residual_after_rms_mm"] = r.residual_after_rms_mm;
  j["apparent_radius_change_mm"] = r.apparent_radius_change_mm;
  j["depth_scale"] = r.depth_scale;
  j["depth_scale_std"] = r.depth_scale_std;
  j["not_determined"] = r.not_determined;
  return j;
}

}  // namespace mlp::calib
