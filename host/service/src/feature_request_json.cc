#include "feature_request_json.h"

#include "mlp/base/check.h"
#include "mlp/base/json_fields.h"
#include "mlp/features/composite.h"
#include "mlp/features/plan.h"
#include "mlp/features/surface.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;
using geometry::Vec3;

const std::string kNom = "request.nominal";

const json& Nominal(const json& r) { return jf::Object<JobInputError>(r, "nominal", "request"); }

// ---- Reading the request ----------------------------------------------------------------

// The tolerance band of the job's size, in the size's unit: {"upper_mm", "lower_mm"} or
// {"upper_deg", "lower_deg"}.
features::SizeSpec Spec(const json& r, const char* key, double nominal, const std::string& unit) {
  const std::string w = std::string("request.") + key;
  const json& tol = jf::Object<JobInputError>(r, key, "request");
  return {nominal, jf::Number<JobInputError>(tol, ("upper_" + unit).c_str(), w),
          jf::Number<JobInputError>(tol, ("lower_" + unit).c_str(), w)};
}

std::optional<double> OptionalNumber(const json& r, const char* key) {
  if (!r.contains(key)) return std::nullopt;
  return jf::Number<JobInputError>(r, key, "request");
}

// request.size, one of `allowed` (the first is the default).
std::string SizeChoice(const json& r,
                       const std::vector<std::string>& allowed,
                       const std::string& message) {
  std::string size = r.value("size", allowed.front());
  if (std::find(allowed.begin(), allowed.end(), size) == allowed.end())
    throw JobInputError("request.size must be " + message);
  return size;
}

features::WidthNominal ParseWidth(const json& n, bool inside) {
  features::WidthNominal w;
  w.centre_mcs = jf::Vector3<JobInputError>(n, "centre_mm", kNom);
  w.direction_mcs = jf::Vector3<JobInputError>(n, "direction", kNom);
  w.width_mm = jf::Number<JobInputError>(n, "width_mm", kNom);
  w.inside = inside;
  w.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", w.band_mm, kNom);
  w.within_mm = jf::NumberOr<JobInputError>(n, "within_mm", w.within_mm, kNom);
  return w;
}

features::RectangleNominal ParseRectangle(const json& j, bool inside) {
  features::RectangleNominal n;
  n.centre_mcs = jf::Vector3<JobInputError>(j, "centre_mm", kNom);
  n.x_direction_mcs = j.contains("x_direction") ? jf::Vector3<JobInputError>(j, "x_direction", kNom)
                                                : Vec3::UnitX();
  n.axis_mcs = j.contains("axis") ? jf::Vector3<JobInputError>(j, "axis", kNom) : Vec3::UnitZ();
  n.size_x_mm = jf::Number<JobInputError>(j, "size_x_mm", kNom);
  n.size_y_mm = jf::Number<JobInputError>(j, "size_y_mm", kNom);
  n.inside = inside;
  n.band_mm = jf::NumberOr<JobInputError>(j, "band_mm", n.band_mm, kNom);
  n.within_mm = jf::NumberOr<JobInputError>(j, "within_mm", n.within_mm, kNom);
  return n;
}

features::StepNominal ParseStep(const json& j) {
  features::StepNominal n;
  n.a = ParsePlaneNominal(jf::Object<JobInputError>(j, "a", kNom), kNom + ".a");
  n.b = ParsePlaneNominal(jf::Object<JobInputError>(j, "b", kNom), kNom + ".b");
  return n;
}

features::AngleNominal ParseAngle(const json& j) {
  features::AngleNominal n;
  n.face = ParsePlaneNominal(jf::Object<JobInputError>(j, "face", kNom), kNom + ".face");
  if (j.contains("datum")) {
    n.datum_face = true;
    n.datum = ParsePlaneNominal(jf::Object<JobInputError>(j, "datum", kNom), kNom + ".datum");
  } else {
    n.datum.normal_mcs = jf::Vector3<JobInputError>(j, "datum_direction", kNom);
  }
  return n;
}

features::PcdNominal ParsePcd(const json& j) {
  features::PcdNominal n;
  if (!j.contains("holes") || !j.at("holes").is_array())
    throw JobInputError("request.nominal.holes must list the holes' nominals");
  for (size_t k = 0; k < j.at("holes").size(); ++k)
    n.holes.push_back(
        ParseBoreNominal(j.at("holes")[k], kNom + ".holes[" + std::to_string(k) + "]"));
  n.centre_mcs = jf::Vector3<JobInputError>(j, "centre_mm", kNom);
  n.diameter_mm = jf::Number<JobInputError>(j, "diameter_mm", kNom);
  return n;
}

features::EllipseNominal ParseEllipse(const json& j, bool inside) {
  features::EllipseNominal n;
  n.top_centre_mcs = jf::Vector3<JobInputError>(j, "top_centre_mm", kNom);
  n.axis_mcs = j.contains("axis") ? jf::Vector3<JobInputError>(j, "axis", kNom) : Vec3::UnitZ();
  n.major_direction_mcs = j.contains("major_direction")
                              ? jf::Vector3<JobInputError>(j, "major_direction", kNom)
                              : Vec3::UnitX();
  n.major_mm = jf::Number<JobInputError>(j, "major_mm", kNom);
  n.minor_mm = jf::Number<JobInputError>(j, "minor_mm", kNom);
  n.depth_mm = jf::Number<JobInputError>(j, "depth_mm", kNom);
  n.inside = inside;
  n.band_mm = jf::NumberOr<JobInputError>(j, "band_mm", n.band_mm, kNom);
  return n;
}

// A vector point file (x y z i j k a line, ~60 bytes) of a million points, at most.
constexpr std::size_t kMaxVectorPointsBytes = 64u << 20;

// {"face": a plane nominal, "point_mm", "wall_normal", "length_mm" (0), "views" (2, or 1 on
// a zero length)}.
features::EdgeNominal ParseEdge(const json& j) {
  features::EdgeNominal n;
  n.face = ParsePlaneNominal(jf::Object<JobInputError>(j, "face", kNom), kNom + ".face");
  n.point_mcs = jf::Vector3<JobInputError>(j, "point_mm", kNom);
  n.wall_normal_mcs = jf::Vector3<JobInputError>(j, "wall_normal", kNom);
  n.length_mm = jf::NumberOr<JobInputError>(j, "length_mm", 0.0, kNom);
  n.views = j.contains("views") ? jf::Integer<JobInputError>(j, "views", kNom)
                                : (n.length_mm > 0.0 ? 2 : 1);
  try {
    n.Check();
  } catch (const features::FeatureError& e) {
    throw JobInputError(kNom + ": " + e.what());
  }
  return n;
}

features::SurfaceNominal SurfaceNominalOf(const json& j, const std::string& data_dir) {
  features::SurfaceNominal n;
  if (j.contains("vector_points_file")) {
    n = features::ParseVectorPoints(
        ReadDataFile(data_dir, jf::Text<JobInputError>(j, "vector_points_file", kNom),
                     "request.nominal.vector_points_file", kMaxVectorPointsBytes));
  } else if (j.contains("points") && j.at("points").is_array()) {
    std::ostringstream text;
    for (const auto& row : j.at("points")) {
      if (!row.is_array() || row.size() != 6)
        throw JobInputError("request.nominal.points holds [x, y, z, i, j, k] rows");
      for (const auto& v : row) {
        if (!v.is_number()) throw JobInputError("request.nominal.points holds numbers");
        text << v.get<double>() << ' ';
      }
      text << '\n';
    }
    n = features::ParseVectorPoints(text.str());
  } else {
    throw JobInputError("request.nominal needs vector_points_file or points");
  }
  n.spacing_mm = jf::NumberOr<JobInputError>(j, "spacing_mm", n.spacing_mm, kNom);
  n.band_mm = jf::NumberOr<JobInputError>(j, "band_mm", n.band_mm, kNom);
  n.best_fit = jf::FlagOr<JobInputError>(j, "best_fit", false, kNom);
  return n;
}

// ---- The table ----------------------------------------------------------------------------

using Shape = jobs::FeatureNominal::Shape;
using jobs::FeatureRequest;

// How a feature's part of the request is read: request.nominal -> the typed nominal; the rest
// of the request -> the size decided on, its spec, other tolerances (request.nominal read).
struct FeatureReader {
  std::function<Shape(const json& nominal, const std::string& data_dir)> nominal;
  std::function<void(const json& request, FeatureRequest*)> sizes;
};

// One feature's reader, written against its own nominal type; Reader() stores it behind the
// variant.
template <class Nominal>
FeatureReader Reader(std::function<Nominal(const json&, const std::string&)> nominal,
                     std::function<void(const json&, const Nominal&, FeatureRequest*)> sizes) {
  return {[p = std::move(nominal)](const json& j, const std::string& dir) -> Shape {
            return p(j, dir);
          },
          [s = std::move(sizes)](const json& r, FeatureRequest* q) {
            s(r, std::get<Nominal>(q->nominal.shape), q);
          }};
}

FeatureReader CylinderReader(bool boss) {
  const char* functional = boss ? "mcc" : "mic";
  return Reader<features::BoreNominal>(
      [boss](const json& j, const std::string&) {
        features::BoreNominal n = ParseBoreNominal(j, kNom);
        n.boss = boss;
        return n;
      },
      [functional](const json& r, const features::BoreNominal& n, FeatureRequest* q) {
        q->size = SizeChoice(r, {"ls", "functional", functional},
                             std::string("ls or functional (") + functional + ")");
        if (q->size != "ls") q->size = "functional";
        q->spec = Spec(r, "tolerance", n.diameter_mm, "mm");
        q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
        q->cylindricity_tol_mm = OptionalNumber(r, "cylindricity_tol_mm");
      });
}

FeatureReader FaceReader() {
  return Reader<features::PlaneNominal>(
      [](const json& j, const std::string&) { return ParsePlaneNominal(j, kNom); },
      [](const json& r, const features::PlaneNominal&, FeatureRequest* q) {
        q->spec = Spec(r, "tolerance", 0.0, "mm");
        q->flatness_tol_mm = OptionalNumber(r, "flatness_tol_mm");
      });
}

FeatureReader WidthReader(bool inside) {
  return Reader<features::WidthNominal>(
      [inside](const json& j, const std::string&) { return ParseWidth(j, inside); },
      [](const json& r, const features::WidthNominal& n, FeatureRequest* q) {
        q->spec = Spec(r, "tolerance", n.width_mm, "mm");
      });
}

FeatureReader RectangleReader(bool inside) {
  return Reader<features::RectangleNominal>(
      [inside](const json& j, const std::string&) { return ParseRectangle(j, inside); },
      [](const json& r, const features::RectangleNominal& n, FeatureRequest* q) {
        q->size = SizeChoice(r, {"x", "y"}, "x or y");
        const bool x = q->size == "x";
        q->spec = Spec(r, "tolerance", x ? n.size_x_mm : n.size_y_mm, "mm");
        q->other_spec = Spec(r, r.contains("tolerance_y") ? "tolerance_y" : "tolerance",
                             x ? n.size_y_mm : n.size_x_mm, "mm");
        q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
      });
}

// A step and an angle: their size's nominal is a field of the nominal no features type holds.
FeatureReader StepReader() {
  return Reader<features::StepNominal>(
      [](const json& j, const std::string&) { return ParseStep(j); },
      [](const json& r, const features::StepNominal&, FeatureRequest* q) {
        const double height_mm = jf::Number<JobInputError>(Nominal(r), "height_mm", kNom);
        q->spec = Spec(r, "tolerance", height_mm, "mm");
      });
}

FeatureReader AngleReader() {
  return Reader<features::AngleNominal>(
      [](const json& j, const std::string&) { return ParseAngle(j); },
      [](const json& r, const features::AngleNominal&, FeatureRequest* q) {
        const double angle_deg = jf::Number<JobInputError>(Nominal(r), "angle_deg", kNom);
        q->spec = Spec(r, "tolerance", angle_deg, "deg");
      });
}

FeatureReader PcdReader() {
  return Reader<features::PcdNominal>(
      [](const json& j, const std::string&) { return ParsePcd(j); },
      [](const json& r, const features::PcdNominal& n, FeatureRequest* q) {
        q->spec = Spec(r, "tolerance", n.diameter_mm, "mm");
        q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
      });
}

FeatureReader EllipseReader(bool inside) {
  return Reader<features::EllipseNominal>(
      [inside](const json& j, const std::string&) { return ParseEllipse(j, inside); },
      [](const json& r, const features::EllipseNominal& n, FeatureRequest* q) {
        q->size = SizeChoice(r, {"major", "minor"}, "major or minor");
        q->spec = Spec(r, "tolerance", q->size == "major" ? n.major_mm : n.minor_mm, "mm");
        q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
      });
}

FeatureReader SurfaceReader() {
  return Reader<features::SurfaceNominal>(
      SurfaceNominalOf, [](const json& r, const features::SurfaceNominal&, FeatureRequest* q) {
        q->spec = {0.0, jf::Number<JobInputError>(r, "profile_tol_mm", "request"), 0.0};
      });
}

FeatureReader EdgeReader() {
  return Reader<features::EdgeNominal>(
      [](const json& j, const std::string&) { return ParseEdge(j); },
      [](const json& r, const features::EdgeNominal&, FeatureRequest* q) {
        q->spec = Spec(r, "tolerance", 0.0, "mm");
      });
}

// A reader for every feature the jobs measure (jobs::FeatureNames), none for any other.
const std::map<std::string, FeatureReader>& Readers() {
  static const std::map<std::string, FeatureReader> readers = [] {
    std::map<std::string, FeatureReader> r = {
        {"bore", CylinderReader(false)},
        {"boss", CylinderReader(true)},
        {"face", FaceReader()},
        {"pocket_width", WidthReader(true)},
        {"web_width", WidthReader(false)},
        {"rect_pocket", RectangleReader(true)},
        {"rect_boss", RectangleReader(false)},
        {"step", StepReader()},
        {"angle", AngleReader()},
        {"pcd", PcdReader()},
        {"ellipse_bore", EllipseReader(true)},
        {"ellipse_boss", EllipseReader(false)},
        {"surface", SurfaceReader()},
        {"edge", EdgeReader()},
    };
    std::vector<std::string> names;
    names.reserve(r.size());
    for (const auto& [name, reader] : r) names.push_back(name);
    MLP_CHECK(names == jobs::FeatureNames());
    return r;
  }();
  return readers;
}

// Throws JobInputError listing the features known when `feature` is not one of them.
const FeatureReader& ReaderNamed(const std::string& feature) {
  const auto it = Readers().find(feature);
  if (it != Readers().end()) return it->second;
  std::string known;
  for (const std::string& name : jobs::FeatureNames()) known += (known.empty() ? "" : ", ") + name;
  throw JobInputError("request.feature \"" + feature + "\" is not one of " + known);
}

}  // namespace

jobs::FeatureNominal ParseFeatureNominal(const json& r, const std::string& data_dir) {
  jobs::FeatureNominal n;
  n.feature = jf::Text<JobInputError>(r, "feature", "request");
  n.shape = ReaderNamed(n.feature).nominal(Nominal(r), data_dir);
  return n;
}

FeatureRequest ParseFeatureRequest(const json& r, const std::string& data_dir) {
  FeatureRequest q;
  q.nominal = ParseFeatureNominal(r, data_dir);
  const FeatureReader& reader = ReaderNamed(q.nominal.feature);
  q.traits = *jobs::TraitsOf(q.nominal.feature);
  reader.sizes(r, &q);
  return q;
}

}  // namespace mlp::service
