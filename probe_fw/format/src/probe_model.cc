#include "mlp/probe_fw/probe_model.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace mlp::probe_fw {
namespace {

using nlohmann::json;
using nlohmann::ordered_json;
namespace jf = base::json_fields;

constexpr const char* kFormat = "mlprobe-probe-model/1";
// The mirror's cubic and the sheet's smile (issue 16): refused by a firmware that predates them.
constexpr const char* kFormatCurved = "mlprobe-probe-model/2";

[[noreturn]] void Fail(const std::string& what) { throw ProbeModelError("probe model: " + what); }

double Number(const json& j, const char* key, const std::string& where) {
  return jf::Number<ProbeModelError>(j, key, "probe model: " + where);
}
int Integer(const json& j, const char* key, const std::string& where) {
  return jf::Integer<ProbeModelError>(j, key, "probe model: " + where);
}
const json& Object(const json& j, const char* key) {
  return jf::Object<ProbeModelError>(j, key, "probe model");
}

void Require(bool ok, const std::string& what) {
  if (!ok) Fail(what);
}

}  // namespace

Vec2 CameraModel::Project(const Vec3& p) const {
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  return {fx_px * xd + cx_px, fy_px * yd + cy_px};
}

Vec2 CameraModel::Undistort(const Vec2& pixel) const {
  const Vec2 target((pixel.x() - cx_px) / fx_px, (pixel.y() - cy_px) / fy_px);
  Vec2 q = target;  // distortion of a lens is a small perturbation: the distorted point starts it
  for (int it = 0; it < 20; ++it) {
    const double x = q.x(), y = q.y(), r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double dradial = k1 + r2 * (2.0 * k2 + 3.0 * r2 * k3);  // d radial / d r2
    const Vec2 f(x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) - target.x(),
                 y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y - target.y());
    // The Jacobian is symmetric and near the identity (a lens's distortion is a perturbation):
    // Cramer's rule solves it; Eigen's pivoting LU was a fifth of the time spent here (perf), and
    // the firmware runs it on every stripe centre (the epipolar index and the triangulation).
    const double a = radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x;
    const double b = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
    const double d = radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
    const double det = a * d - b * b;
    if (!(std::abs(det) > 0.0)) break;  // no step can be taken: a pixel far outside the lens
    const Vec2 step((d * f.x() - b * f.y()) / det, (a * f.y() - b * f.x()) / det);
    q -= step;
    if (step.norm() < 1e-14) break;
  }
  return q;
}

double CameraModel::ApertureSinAt(double depth_mm) const {
  if (f_number <= 0.0 || depth_mm <= 0.0) return 0.0;
  const double pupil_radius_mm = 0.5 * fx_px * pixel_pitch_mm / f_number;
  return pupil_radius_mm / std::hypot(pupil_radius_mm, depth_mm);
}

double ProjectorModel::ColumnOf(const Vec3& point_in_probe) const {
  const Vec3 q = camera_from_projector.inverse() * point_in_probe;
  return c_px + f_px * q.x() / q.z();
}

double ProjectorModel::ActualColumn(double commanded) const {
  const double s = (commanded - c_px) / (0.5 * columns);
  return commanded + mirror_cubic_cols * s * s * s;
}

double ProjectorModel::CommandedColumn(double actual) const {
  if (mirror_cubic_cols == 0.0) return actual;
  constexpr int kSteps = 50;
  constexpr double kTolColumns = 1e-12;
  double u = actual;
  for (int step = 0; step < kSteps; ++step) {
    const double s = (u - c_px) / (0.5 * columns);
    const double du = (u + mirror_cubic_cols * s * s * s - actual) /
                      (1.0 + 3.0 * mirror_cubic_cols * s * s / (0.5 * columns));
    u -= du;
    if (std::abs(du) < kTolColumns) break;
  }
  return u;
}

double ProjectorModel::SmileAt(double t) const {
  const double r = t / std::tan(fan_half_angle_deg / base::kDegPerRad);
  return sheet_smile_cols * r * r;
}

double ProjectorModel::SheetColumnOf(const Vec3& point_in_probe) const {
  const double planar = ColumnOf(point_in_probe);
  if (sheet_smile_cols == 0.0) return planar;
  const Vec3 q = camera_from_projector.inverse() * point_in_probe;
  return planar - SmileAt(q.y() / q.z());
}

void ProjectorModel::PlaneOf(double column, Vec3* normal_in_probe, double* offset_mm) const {
  // In the projector frame the plane holds the y axis and the direction ((u - c) / f, 0, 1).
  const Vec3 n_proj = Vec3(1.0, 0.0, -(column - c_px) / f_px).normalized();
  *normal_in_probe = camera_from_projector.linear() * n_proj;
  *offset_mm = normal_in_probe->dot(camera_from_projector.translation());
}

void ProbeModel::Validate() const {
  const auto& cs = calibration_stats;
  Require(!cs.present || (cs.views >= 0 && cs.corners >= 0 && cs.stripe_points >= 0 &&
                          cs.corner_rms_px >= 0.0 && cs.stripe_rms_columns >= 0.0),
          "calibration_stats must not be negative");
  const auto& c = camera;
  Require(!serial.empty(), "serial must not be empty");
  Require(c.width_px >= 16 && c.width_px <= 16384, "camera.width_px must be 16..16384");
  Require(c.height_px >= 16 && c.height_px <= 16384, "camera.height_px must be 16..16384");
  Require(c.bit_depth >= 8 && c.bit_depth <= 16, "camera.bit_depth must be 8..16");
  Require(c.pixel_pitch_mm > 0.0 && c.pixel_pitch_mm < 0.1,
          "camera.pixel_pitch_mm must be in (0, 0.1)");
  Require(c.fx_px > 0.0 && c.fy_px > 0.0, "camera.fx_px and fy_px must be positive");
  Require(std::abs(c.k1) < 10 && std::abs(c.k2) < 100 && std::abs(c.k3) < 1000 &&
              std::abs(c.p1) < 1 && std::abs(c.p2) < 1,
          "camera distortion coefficients are out of any lens's range");
  Require(c.f_number == 0.0 || (c.f_number >= 0.5 && c.f_number <= 64.0),
          "camera.f_number must be 0.5..64 (or absent)");
  Require(c.focus_distance_mm == 0.0 || (c.focus_distance_mm > 0.0 && c.focus_distance_mm < 1e5),
          "camera.focus_distance_mm must be positive (or absent)");
  const auto& p = projector;
  Require(p.f_px > 0.0, "projector.f_px must be positive");
  Require(p.columns >= 1 && p.columns <= 1 << 20,
          "projector.columns must be 1 (a fixed line laser: one light plane) to 2^20");
  Require(p.camera_from_projector.translation().norm() > 1.0,
          "projector baseline must exceed 1 mm (no triangulation without it)");
  // The actual column must grow with the commanded one (|a| < columns / 6); tens of columns of
  // non-linearity or smile are already far beyond any real mirror or line generator.
  Require(std::abs(p.mirror_cubic_cols) <= 50.0,
          "projector.mirror_cubic_cols must be in [-50, 50]");
  Require(std::abs(p.sheet_smile_cols) <= 50.0, "projector.sheet_smile_cols must be in [-50, 50]");
  Require(p.fan_half_angle_deg > 1.0 && p.fan_half_angle_deg < 80.0,
          "projector.fan_half_angle_deg must be in (1, 80)");
  Require(laser.sheet_halfwidth_cols > 0.0, "laser.sheet_halfwidth_cols must be positive");
  const auto& n = noise;
  Require(n.full_well_e > 0.0, "noise.full_well_e must be positive");
  Require(n.read_noise_e >= 0.0 && n.laser_peak_e >= 0.0 && n.led_e >= 0.0 && n.ambient_e >= 0.0,
          "noise levels must be non-negative");
  // 1: fully developed speckle (one polarisation, coherence length beyond the roughness depth).
  Require(n.speckle_contrast >= 0.0 && n.speckle_contrast <= 1.0,
          "noise.speckle_contrast must be in [0, 1]");
}

ProbeModel ParseProbeModel(const std::string& json_text) {
  const json j = jf::ParseDocument<ProbeModelError>(
      json_text, {std::string(kFormatCurved), std::string(kFormat)}, "probe model");
  ProbeModel m;
  m.serial = jf::Text<ProbeModelError>(j, "serial", "probe model");
  m.calibration_id = jf::Text<ProbeModelError>(j, "calibration_id", "probe model");
  const json& c = Object(j, "camera");
  m.camera.width_px = Integer(c, "width_px", "camera");
  m.camera.height_px = Integer(c, "height_px", "camera");
  m.camera.bit_depth = Integer(c, "bit_depth", "camera");
  m.camera.pixel_pitch_mm = Number(c, "pixel_pitch_mm", "camera");
  m.camera.fx_px = Number(c, "fx_px", "camera");
  m.camera.fy_px = Number(c, "fy_px", "camera");
  m.camera.cx_px = Number(c, "cx_px", "camera");
  m.camera.cy_px = Number(c, "cy_px", "camera");
  const json& d = Object(c, "distortion");
  m.camera.k1 = Number(d, "k1", "camera.distortion");
  m.camera.k2 = Number(d, "k2", "camera.distortion");
  m.camera.p1 = Number(d, "p1", "camera.distortion");
  m.camera.p2 = Number(d, "p2", "camera.distortion");
  m.camera.k3 = Number(d, "k3", "camera.distortion");
  m.camera.f_number = jf::NumberOr<ProbeModelError>(c, "f_number", 0.0, "probe model: camera");
  m.camera.focus_distance_mm =
      jf::NumberOr<ProbeModelError>(c, "focus_distance_mm", 0.0, "probe model: camera");
  const json& p = Object(j, "projector");
  m.projector.f_px = Number(p, "f_px", "projector");
  m.projector.c_px = Number(p, "c_px", "projector");
  m.projector.columns = Integer(p, "columns", "projector");
  m.projector.camera_from_projector = jf::Pose<ProbeModelError>(
      Object(p, "camera_from_projector"), "probe model: projector.camera_from_projector");
  if (j.at("format") == kFormatCurved) {  // a /1 file has a linear mirror and a flat sheet
    m.projector.mirror_cubic_cols = Number(p, "mirror_cubic_cols", "projector");
    m.projector.sheet_smile_cols = Number(p, "sheet_smile_cols", "projector");
    m.projector.fan_half_angle_deg = Number(p, "fan_half_angle_deg", "projector");
  }
  const json& l = Object(j, "laser");
  m.laser.wavelength_nm = Number(l, "wavelength_nm", "laser");
  m.laser.sheet_halfwidth_cols = Number(l, "sheet_halfwidth_cols", "laser");
  const json& n = Object(j, "noise");
  m.noise.full_well_e = Number(n, "full_well_e", "noise");
  m.noise.read_noise_e = Number(n, "read_noise_e", "noise");
  m.noise.laser_peak_e = Number(n, "laser_peak_e", "noise");
  m.noise.led_e = Number(n, "led_e", "noise");
  m.noise.ambient_e = Number(n, "ambient_e", "noise");
  m.noise.speckle_contrast = Number(n, "speckle_contrast", "noise");
  m.noise.stripe_centre_noise_px = Number(n, "stripe_centre_noise_px", "noise");
  if (j.contains("calibration_stats")) {
    const json& cs = Object(j, "calibration_stats");
    auto& s = m.calibration_stats;
    s.present = true;
    s.views = Integer(cs, "views", "calibration_stats");
    s.corners = Integer(cs, "corners", "calibration_stats");
    s.stripe_points = Integer(cs, "stripe_points", "calibration_stats");
    s.corner_rms_px = Number(cs, "corner_rms_px", "calibration_stats");
    s.stripe_rms_columns = Number(cs, "stripe_rms_columns", "calibration_stats");
  }
  m.Validate();
  return m;
}

ProbeModel LoadProbeModel(const std::string& path) {
  return ParseProbeModel(base::ReadFileAs<ProbeModelError>(path, "probe model: "));
}

std::string ToJson(const ProbeModel& m) {
  const auto& c = m.camera;
  ordered_json j;
  // A model with the mirror's or the sheet's terms is a /2 file, which a firmware that would
  // ignore them refuses; any other stays /1, readable by every firmware.
  j["format"] = m.projector.Curved() ? kFormatCurved : kFormat;
  j["serial"] = m.serial;
  j["calibration_id"] = m.calibration_id;
  j["camera"] = {
      {"width_px", c.width_px},
      {"height_px", c.height_px},
      {"bit_depth", c.bit_depth},
      {"pixel_pitch_mm", c.pixel_pitch_mm},
      {"fx_px", c.fx_px},
      {"fy_px", c.fy_px},
      {"cx_px", c.cx_px},
      {"cy_px", c.cy_px},
      {"distortion", {{"k1", c.k1}, {"k2", c.k2}, {"p1", c.p1}, {"p2", c.p2}, {"k3", c.k3}}}};
  // Optional optics: absent when not given, so a model without them reads as it always did.
  if (c.f_number > 0.0) j["camera"]["f_number"] = c.f_number;
  if (c.focus_distance_mm > 0.0) j["camera"]["focus_distance_mm"] = c.focus_distance_mm;
  j["projector"] = {{"f_px", m.projector.f_px},
                    {"c_px", m.projector.c_px},
                    {"columns", m.projector.columns},
                    {"camera_from_projector", jf::PoseToJson(m.projector.camera_from_projector)}};
  if (m.projector.Curved()) {
    j["projector"]["mirror_cubic_cols"] = m.projector.mirror_cubic_cols;
    j["projector"]["sheet_smile_cols"] = m.projector.sheet_smile_cols;
    j["projector"]["fan_half_angle_deg"] = m.projector.fan_half_angle_deg;
  }
  j["laser"] = {{"wavelength_nm", m.laser.wavelength_nm},
                {"sheet_halfwidth_cols", m.laser.sheet_halfwidth_cols}};
  j["noise"] = {{"full_well_e", m.noise.full_well_e},
                {"read_noise_e", m.noise.read_noise_e},
                {"laser_peak_e", m.noise.laser_peak_e},
                {"led_e", m.noise.led_e},
                {"ambient_e", m.noise.ambient_e},
                {"speckle_contrast", m.noise.speckle_contrast},
                {"stripe_centre_noise_px", m.noise.stripe_centre_noise_px}};
  if (m.calibration_stats.present) {
    const auto& cs = m.calibration_stats;
    j["calibration_stats"] = {{"views", cs.views},
                              {"corners", cs.corners},
                              {"stripe_points", cs.stripe_points},
                              {"corner_rms_px", cs.corner_rms_px},
                              {"stripe_rms_columns", cs.stripe_rms_columns}};
  }
  return j.dump(2) + "\n";
}

void SaveProbeModel(const ProbeModel& model, const std::string& path) {
  model.Validate();
  try {
    base::WriteFileAtomically(path, ToJson(model));
  } catch (const base::FileError& e) {
    Fail(e.what());
  }
}

}  // namespace mlp::probe_fw
