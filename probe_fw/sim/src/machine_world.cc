#include "mlp/sim/machine_world.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/sim/scene.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace mlp::sim {
namespace {

using nlohmann::json;
namespace jf = base::json_fields;
using geometry::Pose3;
using geometry::Vec3;

// The turn by `deg` about the line, right-handed about its direction: x -> o + R (x - o).
Pose3 TurnAbout(const RotaryLine& line, double deg) {
  Pose3 turn = Pose3::Identity();
  turn.linear() = Eigen::AngleAxisd(deg / base::kDegPerRad, line.direction).toRotationMatrix();
  turn.translation() = line.point - turn.linear() * line.point;
  return turn;
}

RotaryLine LineOf(const json& j, const char* key) {
  const std::string where = std::string("machine: ") + key;
  const json& o = jf::Object<SceneError>(j, key, "machine");
  jf::OnlyKnownFields<SceneError>(o, {"point_mm", "direction"}, where);
  RotaryLine line;
  line.point = jf::Vector3<SceneError>(o, "point_mm", where);
  const Vec3 d = jf::Vector3<SceneError>(o, "direction", where);
  if (!(d.norm() > 0.5 && d.norm() < 2.0) || !line.point.allFinite())
    throw SceneError(where + ": a finite point and a direction of about unit length");
  line.direction = d.normalized();
  return line;
}

}  // namespace

Pose3 TrunnionWorld::TableFromFlange(const TrunnionJoints& joints) const {
  Pose3 machine_from_flange = Pose3::Identity();
  machine_from_flange.translation() = joints.gauge_machine_mm;
  machine_from_flange.linear() =
      (Eigen::AngleAxisd(joints.spindle_deg / base::kDegPerRad, Vec3::UnitZ()) *
       Eigen::AngleAxisd(base::kPi, Vec3::UnitX()))
          .toRotationMatrix();
  // The table point s is at TurnAbout(a) TurnAbout(c) s in the machine: C rides on the cradle.
  const Pose3 machine_from_table = TurnAbout(a, joints.a_deg) * TurnAbout(c, joints.c_deg);
  return machine_from_table.inverse() * machine_from_flange;
}

TrunnionWorld ParseTrunnionWorld(const std::string& json_text) {
  const json j = json::parse(json_text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw SceneError("machine: not a JSON object");
  jf::OnlyKnownFields<SceneError>(j, {"format", "kind", "a_axis", "c_axis", "joint_pins"},
                                  "machine");
  if (j.value("format", "") != "mlprobe-machine/1" || j.value("kind", "") != "trunnion")
    throw SceneError(
        "machine: format must be \"mlprobe-machine/1\" and kind \"trunnion\" (the only one)");
  TrunnionWorld w;
  w.a = LineOf(j, "a_axis");
  w.c = LineOf(j, "c_axis");
  if (j.contains("joint_pins")) {
    const json& pins = j.at("joint_pins");
    if (!pins.is_array() || pins.size() != 6)
      throw SceneError("machine: joint_pins names six HAL pins: X, Y, Z, A, C, spindle");
    for (size_t i = 0; i < 6; ++i) {
      if (!pins[i].is_string() || pins[i].get<std::string>().empty())
        throw SceneError("machine: joint_pins holds names");
      w.joint_pins[i] = pins[i].get<std::string>();
    }
  }
  return w;
}

TrunnionWorld LoadTrunnionWorld(const std::string& path) {
  return ParseTrunnionWorld(base::ReadFileAs<SceneError>(path, "machine: "));
}

}  // namespace mlp::sim
