#include "mlp/sim/scene.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"

#include <fstream>
#include <sstream>

namespace mlp::sim {
namespace {

using nlohmann::json;
namespace jf = base::json_fields;

constexpr double kDefaultReflectance = 0.5;

[[noreturn]] void Fail(const std::string& what) { throw SceneError("scene: " + what); }

double Positive(const json& j, const char* key, const std::string& where) {
  const double v = jf::Number<SceneError>(j, key, "scene: " + where);
  if (!(v > 0.0)) Fail(where + "." + key + " must be positive");
  return v;
}

Vec3 Vector(const json& j, const char* key, const std::string& where) {
  return jf::Vector3<SceneError>(j, key, "scene: " + where);
}

Vec3 Direction(const json& j, const char* key, const std::string& where) {
  const Vec3 v = Vector(j, key, where);
  if (!(v.norm() > 1e-12)) Fail(where + "." + key + " must not be the zero vector");
  return v.normalized();
}

SolidPtr ParseNode(const json& node, const std::string& where);

// Finishes of machined parts in blue laser light. specular_f0: normal-incidence reflectance of
// the bare metal at 450 nm (iron ~0.55, aluminium ~0.92, from their complex refractive index,
// Rakic et al., Appl. Opt. 37(22), 1998); roughness: the GGX alpha of the lay as seen by the
// probe's aperture (ground Ra ~0.3 um: narrow lobe; milled: wider; cast: broad); diffuse: the
// light scattered out of the lobe (subsurface and multiple scattering on the grain). A matt
// coated reference (sprayed white) is Lambertian. The values are typical, not measured here.
struct Finish {
  const char* name;
  double diffuse;
  Gloss gloss;
};
constexpr Finish kFinishes[] = {
    {"matt_coated", 0.8, {0.0, 1.0}},
    {"ground_steel", 0.08, {0.55, 0.12}},
    {"milled_aluminium", 0.15, {0.92, 0.25}},
    {"cast_iron", 0.12, {0.45, 0.45}},
};

SolidPtr WithMaterial(SolidPtr solid, const json& node, const std::string& where) {
  if (!node.contains("material")) return solid;
  const json& m = node.at("material");
  const std::string w = where + ".material";
  if (m.is_string()) {
    try {
      return MakeNamedFinish(std::move(solid), m.get<std::string>());
    } catch (const SceneError& e) {
      throw SceneError(std::string(e.what()).insert(7, w + ": "));  // after "scene: "
    }
  }
  if (!m.is_object()) Fail(w + " must be a finish name or an object");
  Gloss g;
  g.specular_f0 = jf::Number<SceneError>(m, "specular_f0", "scene: " + w);
  g.roughness = jf::Number<SceneError>(m, "roughness", "scene: " + w);
  const double diffuse = jf::NumberOr<SceneError>(m, "diffuse", -1.0, "scene: " + w);
  if (!(g.specular_f0 >= 0.0 && g.specular_f0 <= 1.0)) Fail(w + ".specular_f0 must be in [0, 1]");
  if (!(g.roughness >= 0.005 && g.roughness <= 1.0)) Fail(w + ".roughness must be in [0.005, 1]");
  if (m.contains("diffuse") && !(diffuse >= 0.0 && diffuse <= 1.0))
    Fail(w + ".diffuse must be in [0, 1]");
  return MakeFinish(std::move(solid), g, diffuse);
}

std::vector<SolidPtr> ParseList(const json& list, const std::string& where) {
  if (!list.is_array() || list.empty()) Fail(where + " must be a non-empty array of solids");
  std::vector<SolidPtr> parts;
  for (size_t i = 0; i < list.size(); ++i) {
    parts.push_back(ParseNode(list[i], where + "[" + std::to_string(i) + "]"));
  }
  return parts;
}

SolidPtr ParsePrimitive(const std::string& kind, const json& p, double refl, const std::string& w) {
  if (kind == "halfspace") {
    return MakeHalfspace(Vector(p, "point", w), Direction(p, "normal", w), refl);
  }
  if (kind == "box") {
    const Vec3 lo = Vector(p, "min", w), hi = Vector(p, "max", w);
    if (!(lo.array() < hi.array()).all()) Fail(w + ": min must be below max on every axis");
    return MakeBox(lo, hi, refl);
  }
  if (kind == "sphere") {
    return MakeSphere(Vector(p, "center", w), Positive(p, "radius", w), refl);
  }
  if (kind == "cylinder") {
    const double r = Positive(p, "radius", w);
    return MakeRevolution(Vector(p, "base", w), Direction(p, "axis", w), Positive(p, "length", w),
                          r, r, refl);
  }
  if (kind == "cone") {
    return MakeRevolution(Vector(p, "base", w), Direction(p, "axis", w), Positive(p, "length", w),
                          Positive(p, "radius_base", w), Positive(p, "radius_top", w), refl);
  }
  if (kind == "chessboard") {
    const int cols = jf::Integer<SceneError>(p, "inner_cols", "scene: " + w);
    const int rows = jf::Integer<SceneError>(p, "inner_rows", "scene: " + w);
    if (cols < 2 || rows < 2 || cols > 100 || rows > 100)
      Fail(w + ": inner_cols and inner_rows must be in 2..100");
    const double dark = jf::NumberOr<SceneError>(p, "dark_reflectance", 0.08, "scene: " + w);
    if (dark < 0.0 || dark > refl) Fail(w + ".dark_reflectance must be in [0, reflectance]");
    return MakeChessboard(jf::Pose<SceneError>(jf::Object<SceneError>(p, "pose", w), w + ".pose"),
                          cols, rows, Positive(p, "square_mm", w), refl, dark);
  }
  Fail(w + ": unknown solid \"" + kind + "\"");
}

SolidPtr ParseSolid(const json& node, const std::string& where) {
  for (const char* op : {"union", "intersection", "difference"}) {
    if (!node.contains(op)) continue;
    auto parts = ParseList(node.at(op), where + "." + op);
    if (std::string(op) == "union") return MakeUnion(std::move(parts));
    if (std::string(op) == "intersection") return MakeIntersection(std::move(parts));
    if (parts.size() < 2) Fail(where + ".difference needs a solid and at least one to subtract");
    SolidPtr first = parts.front();
    parts.erase(parts.begin());
    return MakeDifference(first, std::move(parts));
  }
  const double refl =
      jf::NumberOr<SceneError>(node, "reflectance", kDefaultReflectance, "scene: " + where);
  if (refl < 0.0 || refl > 1.0) Fail(where + ".reflectance must be in [0, 1]");
  for (const char* kind : {"halfspace", "box", "sphere", "cylinder", "cone", "chessboard"}) {
    if (node.contains(kind)) {
      return ParsePrimitive(kind, node.at(kind), refl, where + "." + kind);
    }
  }
  Fail(where +
       ": expected one of halfspace, box, sphere, cylinder, cone, chessboard, union, "
       "intersection, difference");
}

SolidPtr ParseNode(const json& node, const std::string& where) {
  if (!node.is_object()) Fail(where + " must be an object");
  return WithMaterial(ParseSolid(node, where), node, where);
}

}  // namespace

SolidPtr MakeNamedFinish(SolidPtr solid, const std::string& name) {
  for (const Finish& f : kFinishes) {
    if (name == f.name) return MakeFinish(std::move(solid), f.gloss, f.diffuse);
  }
  Fail("unknown finish \"" + name + "\" (matt_coated, ground_steel, milled_aluminium, cast_iron)");
}

Scene ParseScene(const std::string& json_text) {
  const json j = jf::ParseDocument<SceneError>(json_text, "mlprobe-scene/1", "scene");
  Scene scene;
  scene.workpiece = ParseNode(jf::Object<SceneError>(j, "workpiece", "scene"), "workpiece");
  scene.flange_from_probe = jf::Pose<SceneError>(
      jf::Object<SceneError>(j, "flange_from_probe", "scene"), "scene: flange_from_probe");
  if (!j.contains("captures") || !j.at("captures").is_array() || j.at("captures").empty()) {
    Fail("captures must be a non-empty array");
  }
  for (size_t i = 0; i < j.at("captures").size(); ++i) {
    const json& c = j.at("captures")[i];
    const std::string where = "scene: captures[" + std::to_string(i) + "]";
    Capture capture;
    capture.id = jf::Text<SceneError>(c, "id", where);
    capture.mcs_from_flange =
        jf::Pose<SceneError>(jf::Object<SceneError>(c, "mcs_from_flange", where), where);
    scene.captures.push_back(capture);
  }
  return scene;
}

Scene LoadScene(const std::string& path) {
  return ParseScene(base::ReadFileAs<SceneError>(path, "scene: "));
}

}  // namespace mlp::sim
