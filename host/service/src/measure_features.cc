#include "measure_features.h"

#include "mlp/base/json_fields.h"
#include "mlp/jobs/composite.h"
#include "mlp/jobs/plan.h"
#include "mlp/jobs/surface.h"

#include <algorithm>
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

std::string Um(double mm) {
  char s[32];
  std::snprintf(s, sizeof s, "%.1f um", mm * 1e3);
  return s;
}

// The tolerance band of the job's size, in the size's unit: {"upper_mm", "lower_mm"} or
// {"upper_deg", "lower_deg"}.
jobs::SizeSpec Spec(const json& r, const char* key, double nominal, const std::string& unit) {
  const std::string w = std::string("request.") + key;
  const json& tol = jf::Object<JobInputError>(r, key, "request");
  return {nominal, jf::Number<JobInputError>(tol, ("upper_" + unit).c_str(), w),
          jf::Number<JobInputError>(tol, ("lower_" + unit).c_str(), w)};
}

// A second size of the job checked against its own band (no offset follows it).
void CheckSize(const std::string& name, double size, const jobs::SizeSpec& s, Measured* m) {
  const double e = size - s.nominal_mm;
  if (e > s.upper_tol_mm || e < -s.lower_tol_mm)
    m->problems.push_back(name + " " + Um(e) + " from its nominal, outside +" + Um(s.upper_tol_mm) +
                          "/-" + Um(s.lower_tol_mm));
}

// ISO 1101 true position: twice the distance from the nominal position across the axis.
double TruePosition(const Vec3& measured, const Vec3& nominal, const Vec3& axis) {
  const Vec3 a = axis.normalized(), d = measured - nominal;
  return 2 * (d - d.dot(a) * a).norm();
}

void CheckPosition(const json& r, double true_position_mm, const std::string& what, Measured* m) {
  if (!r.contains("position_tol_mm")) return;
  const double tol = jf::Number<JobInputError>(r, "position_tol_mm", "request");
  if (true_position_mm > tol)
    m->problems.push_back(what + " true position " + Um(true_position_mm) + " over " + Um(tol));
}

void AddFace(const jobs::PlaneMeasurement& f, jobs::FitEvidence* fe) {
  fe->points = fe->points == 0 ? f.points : std::min(fe->points, f.points);
  fe->rms_mm = std::max(fe->rms_mm, f.rms_mm);
  fe->area_mm2 = fe->area_mm2 ? std::min(*fe->area_mm2, f.area_mm2) : f.area_mm2;
}

json FaceFields(const jobs::PlaneMeasurement& f) {
  return {{"normal", JsonVec(f.plane.normal)},
          {"height_mm", f.height_mm},
          {"rms_mm", f.rms_mm},
          {"points", f.points},
          {"area_mm2", f.area_mm2}};
}

Measured Cylindrical(const json& r, const Evidence& ev, bool boss) {
  jobs::BoreNominal n = ParseBoreNominal(Nominal(r), kNom);
  n.boss = boss;
  const jobs::BoreMeasurement b = jobs::MeasureBore(ev.points_mcs, n);
  Measured m;
  m.feature = boss ? "boss" : "bore", m.size_name = "diameter";
  const std::string size = r.value("size", std::string("ls"));
  const bool functional = size == "functional" || size == (boss ? "mcc" : "mic");
  if (!functional && size != "ls")
    throw JobInputError(std::string("request.size must be ls or functional (") +
                        (boss ? "mcc" : "mic") + ")");
  if (functional && b.functional_diameter_mm == 0)
    throw jobs::FeatureError(m.feature + ": no functional size from an arc of " +
                             std::to_string(static_cast<int>(b.arc_span_deg)) + " deg");
  m.size = functional ? b.functional_diameter_mm : b.diameter_mm;
  m.spec = Spec(r, "tolerance", n.diameter_mm, "mm");
  // A bore 6 um small: the radius offset drops 3 um; a boss the other way.
  m.change_per_error = boss ? -0.5 : 0.5;
  const double tp = TruePosition(b.top_centre_mcs, n.top_centre_mcs, n.axis_mcs);
  m.fields = {{"diameter_mm", b.diameter_mm},
              {boss ? "diameter_mcc_mm" : "diameter_mic_mm", b.functional_diameter_mm},
              {"centre_mm", JsonVec(b.top_centre_mcs)},
              {"true_position_mm", tp},
              {"rms_mm", b.rms_mm},
              {"points", b.points},
              {"arc_span_deg", b.arc_span_deg}};
  CheckPosition(r, tp, m.feature, &m);
  m.found_mcs = b.top_centre_mcs, m.nominal_mcs = n.top_centre_mcs;
  m.fe.points = b.points;
  m.fe.arc_span_deg = b.arc_span_deg;
  m.fe.rms_mm = b.rms_mm;
  m.fe.converged = b.converged;
  m.bore = b;
  return m;
}

// A face: its height along the nominal normal (tolerance on it, nominal 0) and its flatness.
Measured Face(const json& r, const Evidence& ev) {
  jobs::PlaneNominal n = ParsePlaneNominal(Nominal(r), kNom);
  n.flatness = true;
  const jobs::PlaneMeasurement f = jobs::MeasurePlane(ev.points_mcs, n);
  Measured m;
  m.feature = "face", m.size_name = "height";
  m.size = f.height_mm;
  m.spec = Spec(r, "tolerance", 0.0, "mm");
  m.change_per_error = -1.0;  // a face proud by e: the tool is e shorter than its offset says
  m.moves_length = true;
  m.fields = FaceFields(f);
  m.fields["flatness_mm"] = f.flatness_mm;
  m.fields["trimmed"] = f.trimmed;
  AddFace(f, &m.fe);
  m.panels = {jobs::FacePanel("the face", ev.points_mcs, f)};
  m.nominal_mcs = n.point_mcs;
  m.found_mcs = n.point_mcs + f.height_mm * n.normal_mcs.normalized();
  const double flat_tol = jf::NumberOr<JobInputError>(r, "flatness_tol_mm", 1e9, "request");
  if (f.flatness_mm > flat_tol)
    m.problems.push_back("flatness " + Um(f.flatness_mm) + " over its tolerance " + Um(flat_tol));
  return m;
}

jobs::WidthNominal ParseWidth(const json& n, bool inside) {
  jobs::WidthNominal w;
  w.centre_mcs = jf::Vector3<JobInputError>(n, "centre_mm", kNom);
  w.direction_mcs = jf::Vector3<JobInputError>(n, "direction", kNom);
  w.width_mm = jf::Number<JobInputError>(n, "width_mm", kNom);
  w.inside = inside;
  w.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", w.band_mm, kNom);
  w.within_mm = jf::NumberOr<JobInputError>(n, "within_mm", w.within_mm, kNom);
  return w;
}

// A slot/pocket width (inside) or a web: the distance between two opposite faces.
Measured Width(const json& r, const Evidence& ev, bool inside) {
  const jobs::WidthNominal n = ParseWidth(Nominal(r), inside);
  const jobs::WidthMeasurement w = jobs::MeasureWidth(ev.points_mcs, n);
  Measured m;
  m.feature = inside ? "pocket_width" : "web_width", m.size_name = "width";
  m.size = w.width_mm;
  m.spec = Spec(r, "tolerance", n.width_mm, "mm");
  m.change_per_error = inside ? 0.5 : -0.5;  // the side cutter's radius, as a bore/boss
  m.fields = {{"width_mm", w.width_mm},
              {"centre_mm", JsonVec(w.centre_mcs)},
              {"parallelism_deg", w.parallelism_deg},
              {"face_plus", FaceFields(w.plus)},
              {"face_minus", FaceFields(w.minus)}};
  AddFace(w.plus, &m.fe);
  AddFace(w.minus, &m.fe);
  m.found_mcs = w.centre_mcs, m.nominal_mcs = n.centre_mcs;
  m.panels = {jobs::FacePanel("face at +direction", ev.points_mcs, w.plus),
              jobs::FacePanel("face at -direction", ev.points_mcs, w.minus)};
  return m;
}

// A rectangular pocket or boss: the decision on one size ("x" or "y"), the other held to its
// own band (tolerance_y, default the same band).
jobs::RectangleNominal ParseRectangle(const json& j, bool inside) {
  jobs::RectangleNominal n;
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

Measured Rectangle(const json& r, const Evidence& ev, bool inside) {
  const jobs::RectangleNominal n = ParseRectangle(Nominal(r), inside);
  const jobs::RectangleMeasurement rect = jobs::MeasureRectangle(ev.points_mcs, n);
  const std::string size = r.value("size", std::string("x"));
  if (size != "x" && size != "y") throw JobInputError("request.size must be x or y");
  Measured m;
  m.feature = inside ? "rect_pocket" : "rect_boss", m.size_name = "size";
  const bool x = size == "x";
  m.size = x ? rect.x.width_mm : rect.y.width_mm;
  m.spec = Spec(r, "tolerance", x ? n.size_x_mm : n.size_y_mm, "mm");
  jobs::SizeSpec other = Spec(r, r.contains("tolerance_y") ? "tolerance_y" : "tolerance",
                              x ? n.size_y_mm : n.size_x_mm, "mm");
  CheckSize(x ? "size y" : "size x", x ? rect.y.width_mm : rect.x.width_mm, other, &m);
  m.change_per_error = inside ? 0.5 : -0.5;
  const double tp = TruePosition(rect.centre_mcs, n.centre_mcs, n.axis_mcs);
  m.fields = {{"size_x_mm", rect.x.width_mm},
              {"size_y_mm", rect.y.width_mm},
              {"centre_mm", JsonVec(rect.centre_mcs)},
              {"true_position_mm", tp},
              {"rotation_deg", rect.rotation_deg}};
  CheckPosition(r, tp, m.feature, &m);
  m.found_mcs = rect.centre_mcs, m.nominal_mcs = n.centre_mcs;
  for (const auto* f : {&rect.x.plus, &rect.x.minus, &rect.y.plus, &rect.y.minus})
    AddFace(*f, &m.fe);
  m.panels = {jobs::FacePanel("+x side", ev.points_mcs, rect.x.plus),
              jobs::FacePanel("-x side", ev.points_mcs, rect.x.minus),
              jobs::FacePanel("+y side", ev.points_mcs, rect.y.plus),
              jobs::FacePanel("-y side", ev.points_mcs, rect.y.minus)};
  return m;
}

jobs::StepNominal ParseStep(const json& j) {
  jobs::StepNominal n;
  n.a = ParsePlaneNominal(jf::Object<JobInputError>(j, "a", kNom), kNom + ".a");
  n.b = ParsePlaneNominal(jf::Object<JobInputError>(j, "b", kNom), kNom + ".b");
  return n;
}

Measured Step(const json& r, const Evidence& ev) {
  const json& j = Nominal(r);
  const jobs::StepNominal n = ParseStep(j);
  const jobs::StepMeasurement s = jobs::MeasureStep(ev.points_mcs, n);
  Measured m;
  m.feature = "step", m.size_name = "height";
  m.size = s.height_mm;
  m.spec = Spec(r, "tolerance", jf::Number<JobInputError>(j, "height_mm", kNom), "mm");
  m.change_per_error = -1.0;  // face B cut by the tool to correct: proud by e, e shorter
  m.moves_length = true;
  m.fields = {{"height_mm", s.height_mm},
              {"parallelism_deg", s.parallelism_deg},
              {"face_a", FaceFields(s.a)},
              {"face_b", FaceFields(s.b)}};
  AddFace(s.a, &m.fe);
  AddFace(s.b, &m.fe);
  m.panels = {jobs::FacePanel("face A", ev.points_mcs, s.a),
              jobs::FacePanel("face B", ev.points_mcs, s.b)};
  return m;
}

jobs::AngleNominal ParseAngle(const json& j) {
  jobs::AngleNominal n;
  n.face = ParsePlaneNominal(jf::Object<JobInputError>(j, "face", kNom), kNom + ".face");
  if (j.contains("datum")) {
    n.datum_face = true;
    n.datum = ParsePlaneNominal(jf::Object<JobInputError>(j, "datum", kNom), kNom + ".datum");
  } else {
    n.datum.normal_mcs = jf::Vector3<JobInputError>(j, "datum_direction", kNom);
  }
  return n;
}

Measured Angle(const json& r, const Evidence& ev) {
  const json& j = Nominal(r);
  const jobs::AngleNominal n = ParseAngle(j);
  const jobs::AngleMeasurement a = jobs::MeasureAngle(ev.points_mcs, n);
  Measured m;
  m.feature = "angle", m.size_name = "angle", m.unit = "deg";
  m.size = a.angle_deg;
  m.spec = Spec(r, "tolerance", jf::Number<JobInputError>(j, "angle_deg", kNom), "deg");
  m.fields = {{"angle_deg", a.angle_deg}, {"skew_deg", a.skew_deg}, {"face", FaceFields(a.face)}};
  AddFace(a.face, &m.fe);
  m.panels = {jobs::FacePanel("the face", ev.points_mcs, a.face)};
  if (n.datum_face) {
    m.fields["datum"] = FaceFields(a.datum);
    AddFace(a.datum, &m.fe);
    m.panels.push_back(jobs::FacePanel("the datum", ev.points_mcs, a.datum));
  }
  return m;
}

jobs::PcdNominal ParsePcd(const json& j) {
  jobs::PcdNominal n;
  if (!j.contains("holes") || !j.at("holes").is_array())
    throw JobInputError("request.nominal.holes must list the holes' nominals");
  for (size_t k = 0; k < j.at("holes").size(); ++k)
    n.holes.push_back(
        ParseBoreNominal(j.at("holes")[k], kNom + ".holes[" + std::to_string(k) + "]"));
  n.centre_mcs = jf::Vector3<JobInputError>(j, "centre_mm", kNom);
  n.diameter_mm = jf::Number<JobInputError>(j, "diameter_mm", kNom);
  return n;
}

Measured Pcd(const json& r, const Evidence& ev) {
  const jobs::PcdNominal n = ParsePcd(Nominal(r));
  const jobs::PcdMeasurement p = jobs::MeasurePcd(ev.points_mcs, n);
  Measured m;
  m.feature = "pcd", m.size_name = "diameter";
  m.size = p.diameter_mm;
  m.spec = Spec(r, "tolerance", n.diameter_mm, "mm");
  json holes = json::array();
  m.fe.arc_span_deg = 360.0;
  m.fe.converged = p.converged;
  for (size_t k = 0; k < p.holes.size(); ++k) {
    const jobs::BoreMeasurement& h = p.holes[k];
    holes.push_back({{"centre_mm", JsonVec(h.top_centre_mcs)},
                     {"diameter_mm", h.diameter_mm},
                     {"true_position_mm", p.true_position_mm[k]},
                     {"points", h.points}});
    CheckPosition(r, p.true_position_mm[k], "hole " + std::to_string(k + 1), &m);
    m.panels.push_back(jobs::RingPanel("hole " + std::to_string(k + 1), h));
    m.fe.points = k == 0 ? h.points : std::min(m.fe.points, h.points);
    m.fe.rms_mm = std::max(m.fe.rms_mm, h.rms_mm);
    m.fe.arc_span_deg = std::min(*m.fe.arc_span_deg, h.arc_span_deg);
  }
  m.found_mcs = p.centre_mcs, m.nominal_mcs = n.centre_mcs;
  m.fields = {{"diameter_mm", p.diameter_mm},
              {"centre_mm", JsonVec(p.centre_mcs)},
              {"rotation_deg", p.rotation_deg},
              {"centres_rms_mm", p.rms_mm},
              {"holes", holes}};
  return m;
}

jobs::EllipseNominal ParseEllipse(const json& j, bool inside) {
  jobs::EllipseNominal n;
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

Measured Ellipse(const json& r, const Evidence& ev, bool inside) {
  const jobs::EllipseNominal n = ParseEllipse(Nominal(r), inside);
  const jobs::EllipseMeasurement e = jobs::MeasureEllipse(ev.points_mcs, n);
  const std::string size = r.value("size", std::string("major"));
  if (size != "major" && size != "minor")
    throw JobInputError("request.size must be major or minor");
  Measured m;
  m.feature = inside ? "ellipse_bore" : "ellipse_boss", m.size_name = "diameter";
  const bool major = size == "major";
  m.size = major ? e.major_mm : e.minor_mm;
  m.spec = Spec(r, "tolerance", major ? n.major_mm : n.minor_mm, "mm");
  m.change_per_error = inside ? 0.5 : -0.5;
  const double tp = TruePosition(e.top_centre_mcs, n.top_centre_mcs, n.axis_mcs);
  m.fields = {{"major_mm", e.major_mm},
              {"minor_mm", e.minor_mm},
              {"centre_mm", JsonVec(e.top_centre_mcs)},
              {"true_position_mm", tp},
              {"rotation_deg", e.rotation_deg},
              {"rms_mm", e.rms_mm},
              {"points", e.points}};
  CheckPosition(r, tp, m.feature, &m);
  m.found_mcs = e.top_centre_mcs, m.nominal_mcs = n.top_centre_mcs;
  m.fe.points = e.points;
  m.fe.rms_mm = e.rms_mm;
  m.fe.converged = e.converged;
  return m;
}

// A vector point file (x y z i j k a line, ~60 bytes) of a million points, at most.
constexpr std::size_t kMaxVectorPointsBytes = 64u << 20;

jobs::SurfaceNominal SurfaceNominalOf(const json& j, const std::string& data_dir) {
  jobs::SurfaceNominal n;
  if (j.contains("vector_points_file")) {
    n = jobs::ParseVectorPoints(
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
    n = jobs::ParseVectorPoints(text.str());
  } else {
    throw JobInputError("request.nominal needs vector_points_file or points");
  }
  n.spacing_mm = jf::NumberOr<JobInputError>(j, "spacing_mm", n.spacing_mm, kNom);
  n.band_mm = jf::NumberOr<JobInputError>(j, "band_mm", n.band_mm, kNom);
  return n;
}

// A surface patch against its nominal: the profile (2 max |deviation|) against its tolerance.
// The deviations are the measurement, not fit residuals: the RMS limit does not apply.
Measured Surface(const json& r, const Evidence& ev, const std::string& data_dir) {
  const jobs::SurfaceNominal nominal = SurfaceNominalOf(Nominal(r), data_dir);
  const jobs::SurfaceMeasurement s = jobs::MeasureSurface(ev.points_mcs, nominal);
  Measured m;
  m.feature = "surface", m.size_name = "profile";
  m.size = s.profile_mm;
  m.spec = {0.0, jf::Number<JobInputError>(r, "profile_tol_mm", "request"), 0.0};
  m.fields = {{"profile_mm", s.profile_mm}, {"mean_mm", s.mean_mm},  {"min_mm", s.min_mm},
              {"max_mm", s.max_mm},         {"rms_mm", s.rms_mm},    {"points", s.points},
              {"coverage", s.coverage},     {"area_mm2", s.area_mm2}};
  m.fe.points = s.points;
  m.fe.area_mm2 = s.area_mm2;
  m.panels = {jobs::PointsPanel("against the nominal", s.points_mcs, s.deviation_mm,
                                nominal.normals_mcs.rowwise().sum())};
  return m;
}

using Measure = std::function<Measured(const json&, const Evidence&, const std::string&)>;
using Views = std::function<std::vector<jobs::ViewTarget>(
    const json& nominal, const std::string& data_dir, const jobs::PlanOptions&)>;
struct Feature {
  Measure measure;
  Views views;
};

std::vector<jobs::ViewTarget> Join(std::vector<jobs::ViewTarget> a,
                                   const std::vector<jobs::ViewTarget>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<jobs::ViewTarget> CylinderViews(const json& j, bool boss, const jobs::PlanOptions& o) {
  jobs::BoreNominal n = ParseBoreNominal(j, kNom);
  n.boss = boss;
  return jobs::BoreViews("wall", n, o);
}

std::vector<jobs::ViewTarget> PcdViews(const json& j, const jobs::PlanOptions& o) {
  const jobs::PcdNominal n = ParsePcd(j);
  std::vector<jobs::ViewTarget> views;
  for (size_t k = 0; k < n.holes.size(); ++k)
    views = Join(views, jobs::BoreViews("hole" + std::to_string(k + 1), n.holes[k], o));
  return views;
}

std::vector<jobs::ViewTarget> AngleViews(const json& j, const jobs::PlanOptions& o) {
  const jobs::AngleNominal n = ParseAngle(j);
  auto views = jobs::FaceViews("face", n.face, o);
  return n.datum_face ? Join(views, jobs::FaceViews("datum", n.datum, o)) : views;
}

const std::map<std::string, Feature>& Features() {
  using O = jobs::PlanOptions;
  static const std::map<std::string, Feature> features = {
      {"bore",
       {[](auto& r, auto& ev, auto&) { return Cylindrical(r, ev, false); },
        [](auto& j, auto&, const O& o) { return CylinderViews(j, false, o); }}},
      {"boss",
       {[](auto& r, auto& ev, auto&) { return Cylindrical(r, ev, true); },
        [](auto& j, auto&, const O& o) { return CylinderViews(j, true, o); }}},
      {"face",
       {[](auto& r, auto& ev, auto&) { return Face(r, ev); },
        [](auto& j, auto&, const O& o) {
          return jobs::FaceViews("face", ParsePlaneNominal(j, kNom), o);
        }}},
      {"pocket_width",
       {[](auto& r, auto& ev, auto&) { return Width(r, ev, true); },
        [](auto& j, auto&, const O& o) { return jobs::WidthViews(ParseWidth(j, true), o); }}},
      {"web_width",
       {[](auto& r, auto& ev, auto&) { return Width(r, ev, false); },
        [](auto& j, auto&, const O& o) { return jobs::WidthViews(ParseWidth(j, false), o); }}},
      {"rect_pocket",
       {[](auto& r, auto& ev, auto&) { return Rectangle(r, ev, true); },
        [](auto& j, auto&, const O& o) {
          return jobs::RectangleViews(ParseRectangle(j, true), o);
        }}},
      {"rect_boss",
       {[](auto& r, auto& ev, auto&) { return Rectangle(r, ev, false); },
        [](auto& j, auto&, const O& o) {
          return jobs::RectangleViews(ParseRectangle(j, false), o);
        }}},
      {"step",
       {[](auto& r, auto& ev, auto&) { return Step(r, ev); },
        [](auto& j, auto&, const O& o) {
          const jobs::StepNominal n = ParseStep(j);
          return Join(jobs::FaceViews("face_a", n.a, o), jobs::FaceViews("face_b", n.b, o));
        }}},
      {"angle",
       {[](auto& r, auto& ev, auto&) { return Angle(r, ev); },
        [](auto& j, auto&, const O& o) { return AngleViews(j, o); }}},
      {"pcd",
       {[](auto& r, auto& ev, auto&) { return Pcd(r, ev); },
        [](auto& j, auto&, const O& o) { return PcdViews(j, o); }}},
      {"ellipse_bore",
       {[](auto& r, auto& ev, auto&) { return Ellipse(r, ev, true); },
        [](auto& j, auto&, const O& o) { return jobs::EllipseViews(ParseEllipse(j, true), o); }}},
      {"ellipse_boss",
       {[](auto& r, auto& ev, auto&) { return Ellipse(r, ev, false); },
        [](auto& j, auto&, const O& o) { return jobs::EllipseViews(ParseEllipse(j, false), o); }}},
      {"surface",
       {[](auto& r, auto& ev, auto& dir) { return Surface(r, ev, dir); },
        [](auto& j, auto& dir, const O& o) {
          return jobs::SurfaceViews(SurfaceNominalOf(j, dir), o);
        }}},
  };
  return features;
}

}  // namespace

void CheckFeatureName(const std::string& feature) {
  if (Features().count(feature)) return;
  std::string known;
  for (const auto& [name, f] : Features()) known += (known.empty() ? "" : ", ") + name;
  throw JobInputError("request.feature \"" + feature + "\" is not one of " + known);
}

Measured MeasureFeature(const json& r, const Evidence& ev, const std::string& data_dir) {
  const std::string feature = jf::Text<JobInputError>(r, "feature", "request");
  CheckFeatureName(feature);
  return Features().at(feature).measure(r, ev, data_dir);
}

std::vector<jobs::ViewTarget> FeatureViews(const json& r,
                                           const std::string& data_dir,
                                           const jobs::PlanOptions& options) {
  const std::string feature = jf::Text<JobInputError>(r, "feature", "request");
  CheckFeatureName(feature);
  return Features().at(feature).views(Nominal(r), data_dir, options);
}

}  // namespace mlp::service
