#include "mlp/grind/grind_job.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/geometry/error.h"
#include "mlp/grey_image/grey_image.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include <nlohmann/json.hpp>

namespace mlp::grind {
namespace {

using geometry::Vec2;
namespace jf = base::json_fields;

Vec2 Pair(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 2 || !j[0].is_number() || !j[1].is_number())
    throw GrindInputError(where + " must be [x, y] in mm");
  return {j[0].get<double>(), j[1].get<double>()};
}

nlohmann::json Pair(const Vec2& v) { return {v.x(), v.y()}; }

// Where the line from C along u leaves the real wheel (its nose's centre C + offset): the far
// crossing (the side towards the material); NaN when the line misses it (an offset beyond the
// nose: no fair case).
double OnRealWheel(const Vec2& offset, const Vec2& u, const WheelSection& real) {
  const std::vector<double> t = real.Crossings(-offset, u);
  return t.empty() ? std::nan("") : t.back();
}

}  // namespace

std::vector<geometry::ProfileSegment> DemoProfile() {
  const double s = std::sqrt(0.5);
  const Vec2 a(0.05, 2.0), b(1.5, 2.0), c1(1.5, 1.2);
  const Vec2 arc1_end = c1 + 0.8 * Vec2(s, s);
  const Vec2 flank_end = arc1_end + 0.8 * Vec2(s, -s);
  const Vec2 c2 = flank_end + 1.5 * Vec2(s, s);
  const Vec2 arc2_end = c2 + 1.5 * Vec2(0, -1);
  return {{a, b, false, Vec2::Zero(), true},
          {b, arc1_end, true, c1, false},
          {arc1_end, flank_end, false, Vec2::Zero(), true},
          {flank_end, arc2_end, true, c2, true},
          {arc2_end, Vec2(5.0, arc2_end.y()), false, Vec2::Zero(), true}};
}

std::vector<ErrorCase> SweepCases(const geometry::Profile2& p,
                                  double r,
                                  double e,
                                  int n,
                                  unsigned seed,
                                  const WheelBevel& bevel) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<ErrorCase> cases;
  while (static_cast<int>(cases.size()) < n) {
    const int kind = static_cast<int>(cases.size()) % 4;
    ErrorCase c;
    c.s_mm = 0.4 + (p.Length() - 0.8) * unit(rng);
    const geometry::ProfileFoot f = p.At(c.s_mm);
    const Vec2 t(f.normal.y(), -f.normal.x());  // along the profile
    const double size = (1.5 + 3.5 * unit(rng)) * e, side = (2 * unit(rng) - 1);
    if (kind == 0) c.offset_mm = f.normal * (0.4 * e * side) + t * (e * (2 * unit(rng) - 1));
    if (kind == 1) c.offset_mm = f.normal * size + t * (3 * e * side);
    if (kind == 2) c.offset_mm = -f.normal * size + t * (2 * e * side);
    if (kind == 3) c.wear_mm = size;
    c.mi_mm = f.point, c.c_mm = f.point + r * f.normal;
    const double t_real = OnRealWheel(c.offset_mm, -f.normal, WheelSection(r - c.wear_mm, bevel));
    c.d_mm = std::abs(t_real - r);
    if (!(std::abs(c.d_mm - e) >= 0.2 * e)) continue;  // too near the limit, or no crossing
    c.feed = c.d_mm <= e ? Feed::kGood : t_real < r ? Feed::kUnderFeed : Feed::kOverFeed;
    c.error_dir = c.wear_mm > 0 ? f.normal : Vec2(c.offset_mm.normalized());
    c.error_mm = c.wear_mm > 0 ? c.wear_mm : c.offset_mm.norm();
    cases.push_back(c);
  }
  return cases;
}

void RenderCase(const geometry::Profile2& nominal,
                const GrindJob& job,
                const ErrorCase& c,
                unsigned seed,
                std::vector<std::uint8_t>* before,
                std::vector<std::uint8_t>* after) {
  *before = RenderGrindFrame(nominal, job.stock_mm, {}, job.camera, seed, job.bevel);
  const WheelStroke stroke{c.c_mm + c.offset_mm, job.wheel_radius_mm - c.wear_mm};
  *after = RenderGrindFrame(nominal, job.stock_mm, {stroke}, job.camera, seed + 1, job.bevel);
}

void WritePgm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& px) {
  try {
    grey_image::WritePgm(path, w, h, px);
  } catch (const base::FileError& e) {  // base's error, once, at this module's edge
    throw GrindError(e.what());
  }
}

GrindJob ParseJob(const std::string& text, const std::string& where) {
  using E = GrindInputError;
  const auto j = jf::ParseDocument<E>(text, "mlprobe-grind/1", where);
  GrindJob g;
  const auto& cam = jf::Object<E>(j, "camera", where);
  g.camera.width_px = jf::Integer<E>(cam, "width_px", "camera");
  g.camera.height_px = jf::Integer<E>(cam, "height_px", "camera");
  g.camera.mm_per_px = jf::Number<E>(cam, "mm_per_px", "camera");
  g.camera.origin_x_mm = jf::Number<E>(cam, "origin_x_mm", "camera");
  g.camera.origin_y_mm = jf::Number<E>(cam, "origin_y_mm", "camera");
  g.camera.Validate();
  g.wheel_radius_mm = jf::Number<E>(j, "wheel_radius_mm", where);
  g.limit_mm = jf::Number<E>(j, "limit_mm", where);
  g.stock_mm = jf::NumberOr<E>(j, "stock_mm", g.stock_mm, where);
  if (!(g.wheel_radius_mm > 0) || !(g.limit_mm > 0)) throw E(where + ": R, e > 0");
  if (j.contains("bevel")) {  // a double-bevel wheel (wheel.h)
    const auto& b = jf::Object<E>(j, "bevel", where);
    g.bevel.on = true;
    g.bevel.half_angle_deg = jf::Number<E>(b, "half_angle_deg", "bevel");
    g.bevel.tip_dir = Pair(b.value("tip_dir", nlohmann::json()), "bevel.tip_dir");
    g.bevel.Validate();
  }
  if (!j.contains("profile") || !j.at("profile").is_array())
    throw E(where + ": profile must list segments");
  for (size_t k = 0; k < j.at("profile").size(); ++k) {
    const auto& s = j.at("profile")[k];
    const std::string w = "profile[" + std::to_string(k) + "]";
    geometry::ProfileSegment seg;
    seg.start = Pair(s.value("start", nlohmann::json()), w + ".start");
    seg.end = Pair(s.value("end", nlohmann::json()), w + ".end");
    seg.arc = s.contains("center");
    if (seg.arc) {
      seg.center = Pair(s.at("center"), w + ".center");
      seg.ccw = jf::FlagOr<E>(s, "ccw", true, w);
    }
    g.profile.push_back(seg);
  }
  if (!j.contains("points") || !j.at("points").is_array())
    throw E(where + ": points must list the cutting points");
  for (size_t k = 0; k < j.at("points").size(); ++k) {
    const auto& p = j.at("points")[k];
    const std::string w = "points[" + std::to_string(k) + "]";
    g.points.push_back({jf::Text<E>(p, "before", w), jf::Text<E>(p, "after", w),
                        Pair(p.value("c_mm", nlohmann::json()), w + ".c_mm"),
                        Pair(p.value("mi_mm", nlohmann::json()), w + ".mi_mm")});
  }
  try {  // the profile a measurement follows: continuous, arcs on their circles, no empty segment
    const geometry::Profile2 check(g.profile);
  } catch (const geometry::GeometryError& e) {
    throw E(where + ": " + e.what());
  }
  return g;
}

std::string JobJson(const GrindJob& g) {
  nlohmann::ordered_json profile = nlohmann::ordered_json::array();
  for (const auto& s : g.profile) {
    nlohmann::ordered_json seg = {{"start", Pair(s.start)}, {"end", Pair(s.end)}};
    if (s.arc) seg["center"] = Pair(s.center), seg["ccw"] = s.ccw;
    profile.push_back(seg);
  }
  nlohmann::ordered_json points = nlohmann::ordered_json::array();
  for (const auto& p : g.points)
    points.push_back({{"before", p.before},
                      {"after", p.after},
                      {"c_mm", Pair(p.c_mm)},
                      {"mi_mm", Pair(p.mi_mm)}});
  nlohmann::ordered_json j = {{"format", "mlprobe-grind/1"},
                              {"camera",
                               {{"width_px", g.camera.width_px},
                                {"height_px", g.camera.height_px},
                                {"mm_per_px", g.camera.mm_per_px},
                                {"origin_x_mm", g.camera.origin_x_mm},
                                {"origin_y_mm", g.camera.origin_y_mm}}},
                              {"wheel_radius_mm", g.wheel_radius_mm},
                              {"limit_mm", g.limit_mm},
                              {"stock_mm", g.stock_mm},
                              {"profile", profile},
                              {"points", points}};
  if (g.bevel.on)
    j["bevel"] = {{"half_angle_deg", g.bevel.half_angle_deg}, {"tip_dir", Pair(g.bevel.tip_dir)}};
  return j.dump(1) + "\n";
}

}  // namespace mlp::grind
