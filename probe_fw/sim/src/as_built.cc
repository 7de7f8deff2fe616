#include "mlp/sim/as_built.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/probe_fw/triangulate.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <Eigen/Geometry>

namespace mlp::sim {
namespace {

namespace jf = base::json_fields;
using nlohmann::json;

constexpr const char* kFormat = "mlprobe-as-built/1";
// A window's normal this far off the optical axis (or more) is a design error, not a tolerance.
constexpr double kMaxWindowTiltDeg = 30.0;

[[noreturn]] void Fail(const std::string& what) { throw AsBuiltError(what); }

AsBuiltOptics ParseOptics(const json& j) {
  jf::OnlyKnownFields<AsBuiltError>(j, {"format", "model", "window"}, "as-built");
  AsBuiltOptics o;
  if (j.contains("window")) {
    const json& w = jf::Object<AsBuiltError>(j, "window", "as-built");
    jf::OnlyKnownFields<AsBuiltError>(w, {"thickness_mm", "refractive_index", "normal_in_probe"},
                                      "as-built.window");
    o.window_thickness_mm = jf::Number<AsBuiltError>(w, "thickness_mm", "as-built.window");
    o.window_index = jf::Number<AsBuiltError>(w, "refractive_index", "as-built.window");
    if (w.contains("normal_in_probe"))
      o.window_normal_in_probe = jf::Vector3<AsBuiltError>(w, "normal_in_probe", "as-built.window");
  }
  return o;
}

}  // namespace

void AsBuiltOptics::Validate() const {
  if (!(window_thickness_mm >= 0.0 && window_thickness_mm <= 20.0))
    Fail("as-built: window.thickness_mm must be in [0, 20]");
  if (!(window_index >= 1.0 && window_index <= 4.0))
    Fail("as-built: window.refractive_index must be in [1, 4]");
  const double norm = window_normal_in_probe.norm();
  if (!(norm > 0.0) || !window_normal_in_probe.allFinite())
    Fail("as-built: window.normal_in_probe must be a non-zero vector");
  if (window_normal_in_probe.z() / norm < std::cos(kMaxWindowTiltDeg / base::kDegPerRad))
    Fail("as-built: window.normal_in_probe must be within 30 degrees of the probe's z axis");
}

// Snell's law at both faces: inside the plate the ray runs along d_r (tangential part of d
// divided by the index); it leaves parallel to d. Against the ray that went straight on, it is
// moved by T / cos(phi_r) d_r - T / cos(phi) d, which has no part along the normal (both cross
// the plate's thickness T).
Vec3 AsBuiltOptics::WindowShift(const Vec3& d) const {
  if (window_thickness_mm == 0.0) return Vec3::Zero();
  const Vec3 n = window_normal_in_probe.normalized();
  const double cos_in = d.dot(n);  // > 0: the camera looks through the window
  const Vec3 tangential = d - cos_in * n;
  const double sin_r = tangential.norm() / window_index;
  const double cos_r = std::sqrt(1.0 - sin_r * sin_r);
  const Vec3 inside = tangential / window_index + cos_r * n;
  return window_thickness_mm / cos_r * inside - window_thickness_mm / cos_in * d;
}

void WorkingVolumePoints(const AsBuiltProbe& truth,
                         const probe_fw::ProbeModel& model,
                         const probe_fw::Aoi* aoi,
                         std::vector<Vec3>* triangulated,
                         std::vector<Vec3>* true_points) {
  const auto& cam = truth.model.camera;
  const auto& proj = truth.model.projector;
  const double step = aoi ? 20.0 : 150.0;
  const double u0 = aoi ? aoi->x0 : 100.0, u1 = aoi ? aoi->x0 + aoi->width : cam.width_px - 100.0;
  const double w0 = aoi ? aoi->y0 : 100.0, w1 = aoi ? aoi->y0 + aoi->height : cam.height_px - 100.0;
  for (double z : {105.0, 120.0, 135.0}) {
    for (double u = u0; u < u1; u += step) {
      for (double w = w0; w < w1; w += step) {
        const geometry::Vec2 xy = cam.Undistort(geometry::Vec2(u, w));
        const Vec3 d = Vec3(xy.x(), xy.y(), 1.0).normalized();
        const Vec3 o = truth.optics.WindowShift(d);
        const Vec3 p = o + d * ((z - o.z()) / d.z());
        const double column = proj.CommandedColumnOf(p);
        if (column < 0 || column > proj.columns - 1) continue;
        const auto seen = probe_fw::Triangulate(model, u, w, column);
        if (!seen) continue;  // a ray along the light plane: no depth to compare
        triangulated->push_back(*seen);
        true_points->push_back(p);
      }
    }
  }
}

Pose3 TrueFromModelFrame(const AsBuiltProbe& truth,
                         const probe_fw::ProbeModel& model,
                         const probe_fw::Aoi* aoi,
                         double* rms_mm) {
  std::vector<Vec3> got, want;
  WorkingVolumePoints(truth, model, aoi, &got, &want);
  if (got.size() < 3) throw AsBuiltError("as built: no point of the working volume is lit");
  Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(got.size())), b = a;
  for (size_t i = 0; i < got.size(); ++i)
    a.col(static_cast<Eigen::Index>(i)) = got[i], b.col(static_cast<Eigen::Index>(i)) = want[i];
  const Eigen::Matrix4d t = Eigen::umeyama(a, b, false);
  Pose3 out = Pose3::Identity();
  out.linear() = t.topLeftCorner<3, 3>();
  out.translation() = t.topRightCorner<3, 1>();
  if (rms_mm) {
    *rms_mm = std::sqrt(
        ((out.linear() * a).colwise() + out.translation() - b).colwise().squaredNorm().mean());
  }
  return out;
}

AsBuiltProbe ParseAsBuilt(const std::string& json_text) {
  const json j =
      jf::ParseDocument<AsBuiltError>(json_text,
                                      {std::string(kFormat), std::string("mlprobe-probe-model/2"),
                                       std::string("mlprobe-probe-model/1")},
                                      "as-built");
  AsBuiltProbe a;
  if (j.at("format") != kFormat) {  // a plain probe model: the probe exactly as modelled
    a.model = probe_fw::ParseProbeModel(json_text);
    a.plain_model = true;
    return a;
  }
  a.model = probe_fw::ParseProbeModel(jf::Object<AsBuiltError>(j, "model", "as-built").dump());
  a.optics = ParseOptics(j);
  a.optics.Validate();
  return a;
}

AsBuiltProbe LoadAsBuilt(const std::string& path) {
  return ParseAsBuilt(base::ReadFileAs<AsBuiltError>(path, "as-built: "));
}

}  // namespace mlp::sim
