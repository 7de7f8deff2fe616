#include "measure_features.h"

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

std::string Um(double mm) {
  char s[32];
  std::snprintf(s, sizeof s, "%.1f um", mm * 1e3);
  return s;
}

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

// ---- Measuring ----------------------------------------------------------------------------

// A second size of the job checked against its own band (no offset follows it).
void CheckSize(const std::string& name, double size, const features::SizeSpec& s, Measured* m) {
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

void CheckPosition(const FeatureRequest& q,
                   double true_position_mm,
                   const std::string& what,
                   Measured* m) {
  if (q.position_tol_mm && true_position_mm > *q.position_tol_mm)
    m->problems.push_back(what + " true position " + Um(true_position_mm) + " over " +
                          Um(*q.position_tol_mm));
}

void AddFace(const features::PlaneMeasurement& f, features::FitEvidence* fe) {
  fe->points = fe->points == 0 ? f.points : std::min(fe->points, f.points);
  fe->rms_mm = std::max(fe->rms_mm, f.rms_mm);
  fe->area_mm2 = fe->area_mm2 ? std::min(*fe->area_mm2, f.area_mm2) : f.area_mm2;
}

json FaceFields(const features::PlaneMeasurement& f) {
  return {{"normal", JsonVec(f.plane.normal)},
          {"height_mm", f.height_mm},
          {"height_u_mm", f.height_u_mm},
          {"rms_mm", f.rms_mm},
          {"points", f.points},
          {"area_mm2", f.area_mm2}};
}

Measured Cylindrical(const FeatureRequest& q,
                     const features::BoreNominal& nominal,
                     const Evidence& ev) {
  features::BoreNominal n = nominal;
  n.cylindricity = q.cylindricity_tol_mm.has_value();  // a Chebyshev fit only where asked
  const features::BoreMeasurement b = features::MeasureBore(ev.points_mcs, n);
  Measured m;
  const bool functional = q.size != "ls";
  if (functional && b.functional_diameter_mm == 0)
    throw features::FeatureError(q.nominal.feature + ": no functional size from an arc of " +
                                 std::to_string(static_cast<int>(b.arc_span_deg)) + " deg");
  m.size = functional ? b.functional_diameter_mm : b.diameter_mm;
  const double tp = TruePosition(b.top_centre_mcs, n.top_centre_mcs, n.axis_mcs);
  m.fields = {{"diameter_mm", b.diameter_mm},
              {"diameter_u_mm", b.diameter_u_mm},
              {n.boss ? "diameter_mcc_mm" : "diameter_mic_mm", b.functional_diameter_mm},
              {"centre_mm", JsonVec(b.top_centre_mcs)},
              {"true_position_mm", tp},
              {"rms_mm", b.rms_mm},
              {"points", b.points},
              {"arc_span_deg", b.arc_span_deg}};
  CheckPosition(q, tp, q.nominal.feature, &m);
  if (n.cylindricity) {
    m.fields["cylindricity_mm"] = b.cylindricity_mm;
    if (b.cylindricity_mm > *q.cylindricity_tol_mm)
      m.problems.push_back("cylindricity " + Um(b.cylindricity_mm) + " over its tolerance " +
                           Um(*q.cylindricity_tol_mm));
  }
  m.found_mcs = b.top_centre_mcs, m.nominal_mcs = n.top_centre_mcs;
  m.fe.points = b.points;
  m.fe.arc_span_deg = b.arc_span_deg;
  m.fe.rms_mm = b.rms_mm;
  // The functional size's own fit counts when it is the size decided on; the cylindricity's
  // when a tolerance holds the part to it.
  m.fe.converged =
      b.converged && (!functional || b.functional_converged) && b.cylindricity_converged;
  m.bore = b;
  return m;
}

// A face: its height along the nominal normal (tolerance on it, nominal 0) and its flatness.
Measured Face(const FeatureRequest& q, const features::PlaneNominal& nominal, const Evidence& ev) {
  features::PlaneNominal n = nominal;
  n.flatness = true;
  const features::PlaneMeasurement f = features::MeasurePlane(ev.points_mcs, n);
  Measured m;
  m.size = f.height_mm;
  m.fields = FaceFields(f);
  m.fields["flatness_mm"] = f.flatness_mm;
  m.fields["trimmed"] = f.trimmed;
  AddFace(f, &m.fe);
  m.fe.converged = f.flatness_converged;
  m.panels = {features::FacePanel("the face", ev.points_mcs, f)};
  m.nominal_mcs = n.point_mcs;
  m.found_mcs = n.point_mcs + f.height_mm * n.normal_mcs.normalized();
  if (q.flatness_tol_mm && f.flatness_mm > *q.flatness_tol_mm)
    m.problems.push_back("flatness " + Um(f.flatness_mm) + " over its tolerance " +
                         Um(*q.flatness_tol_mm));
  return m;
}

// A slot/pocket width (inside) or a web: the distance between two opposite faces.
Measured Width(const FeatureRequest& /*request*/,
               const features::WidthNominal& n,
               const Evidence& ev) {
  const features::WidthMeasurement w = features::MeasureWidth(ev.points_mcs, n);
  Measured m;
  m.size = w.width_mm;
  m.fields = {{"width_mm", w.width_mm},
              {"width_u_mm", w.width_u_mm},
              {"centre_mm", JsonVec(w.centre_mcs)},
              {"parallelism_deg", w.parallelism_deg},
              {"face_plus", FaceFields(w.plus)},
              {"face_minus", FaceFields(w.minus)}};
  AddFace(w.plus, &m.fe);
  AddFace(w.minus, &m.fe);
  m.found_mcs = w.centre_mcs, m.nominal_mcs = n.centre_mcs;
  m.panels = {features::FacePanel("face at +direction", ev.points_mcs, w.plus),
              features::FacePanel("face at -direction", ev.points_mcs, w.minus)};
  return m;
}

// A rectangular pocket or boss: the decision on one size ("x" or "y"), the other held to its
// own band (tolerance_y, default the same band).
Measured Rectangle(const FeatureRequest& q,
                   const features::RectangleNominal& n,
                   const Evidence& ev) {
  const features::RectangleMeasurement rect = features::MeasureRectangle(ev.points_mcs, n);
  Measured m;
  const bool x = q.size == "x";
  m.size = x ? rect.x.width_mm : rect.y.width_mm;
  CheckSize(x ? "size y" : "size x", x ? rect.y.width_mm : rect.x.width_mm, *q.other_spec, &m);
  const double tp = TruePosition(rect.centre_mcs, n.centre_mcs, n.axis_mcs);
  m.fields = {{"size_x_mm", rect.x.width_mm},          {"size_x_u_mm", rect.x.width_u_mm},
              {"size_y_mm", rect.y.width_mm},          {"size_y_u_mm", rect.y.width_u_mm},
              {"centre_mm", JsonVec(rect.centre_mcs)}, {"true_position_mm", tp},
              {"rotation_deg", rect.rotation_deg}};
  CheckPosition(q, tp, q.nominal.feature, &m);
  m.found_mcs = rect.centre_mcs, m.nominal_mcs = n.centre_mcs;
  for (const auto* f : {&rect.x.plus, &rect.x.minus, &rect.y.plus, &rect.y.minus})
    AddFace(*f, &m.fe);
  m.panels = {features::FacePanel("+x side", ev.points_mcs, rect.x.plus),
              features::FacePanel("-x side", ev.points_mcs, rect.x.minus),
              features::FacePanel("+y side", ev.points_mcs, rect.y.plus),
              features::FacePanel("-y side", ev.points_mcs, rect.y.minus)};
  return m;
}

Measured Step(const FeatureRequest& /*request*/,
              const features::StepNominal& n,
              const Evidence& ev) {
  const features::StepMeasurement s = features::MeasureStep(ev.points_mcs, n);
  Measured m;
  m.size = s.height_mm;
  m.fields = {{"height_mm", s.height_mm},
              {"height_u_mm", s.height_u_mm},
              {"parallelism_deg", s.parallelism_deg},
              {"face_a", FaceFields(s.a)},
              {"face_b", FaceFields(s.b)}};
  AddFace(s.a, &m.fe);
  AddFace(s.b, &m.fe);
  m.panels = {features::FacePanel("face A", ev.points_mcs, s.a),
              features::FacePanel("face B", ev.points_mcs, s.b)};
  return m;
}

Measured Angle(const FeatureRequest& /*request*/,
               const features::AngleNominal& n,
               const Evidence& ev) {
  const features::AngleMeasurement a = features::MeasureAngle(ev.points_mcs, n);
  Measured m;
  m.size = a.angle_deg;
  m.fields = {{"angle_deg", a.angle_deg},
              {"angle_u_deg", a.angle_u_deg},
              {"skew_deg", a.skew_deg},
              {"face", FaceFields(a.face)}};
  AddFace(a.face, &m.fe);
  m.panels = {features::FacePanel("the face", ev.points_mcs, a.face)};
  if (n.datum_face) {
    m.fields["datum"] = FaceFields(a.datum);
    AddFace(a.datum, &m.fe);
    m.panels.push_back(features::FacePanel("the datum", ev.points_mcs, a.datum));
  }
  return m;
}

Measured Pcd(const FeatureRequest& q, const features::PcdNominal& n, const Evidence& ev) {
  const features::PcdMeasurement p = features::MeasurePcd(ev.points_mcs, n);
  Measured m;
  m.size = p.diameter_mm;
  json holes = json::array();
  m.fe.arc_span_deg = 360.0;
  m.fe.converged = p.converged;
  for (size_t k = 0; k < p.holes.size(); ++k) {
    const features::BoreMeasurement& h = p.holes[k];
    holes.push_back({{"centre_mm", JsonVec(h.top_centre_mcs)},
                     {"diameter_mm", h.diameter_mm},
                     {"diameter_u_mm", h.diameter_u_mm},
                     {"true_position_mm", p.true_position_mm[k]},
                     {"points", h.points}});
    CheckPosition(q, p.true_position_mm[k], "hole " + std::to_string(k + 1), &m);
    m.panels.push_back(features::RingPanel("hole " + std::to_string(k + 1), h));
    m.fe.points = k == 0 ? h.points : std::min(m.fe.points, h.points);
    m.fe.rms_mm = std::max(m.fe.rms_mm, h.rms_mm);
    m.fe.arc_span_deg = std::min(*m.fe.arc_span_deg, h.arc_span_deg);
  }
  m.found_mcs = p.centre_mcs, m.nominal_mcs = n.centre_mcs;
  m.fields = {{"diameter_mm", p.diameter_mm},       {"diameter_u_mm", p.diameter_u_mm},
              {"centre_mm", JsonVec(p.centre_mcs)}, {"rotation_deg", p.rotation_deg},
              {"centres_rms_mm", p.rms_mm},         {"holes", holes}};
  return m;
}

Measured Ellipse(const FeatureRequest& q, const features::EllipseNominal& n, const Evidence& ev) {
  const features::EllipseMeasurement e = features::MeasureEllipse(ev.points_mcs, n);
  Measured m;
  m.size = q.size == "major" ? e.major_mm : e.minor_mm;
  const double tp = TruePosition(e.top_centre_mcs, n.top_centre_mcs, n.axis_mcs);
  m.fields = {{"major_mm", e.major_mm},
              {"major_u_mm", e.major_u_mm},
              {"minor_mm", e.minor_mm},
              {"minor_u_mm", e.minor_u_mm},
              {"centre_mm", JsonVec(e.top_centre_mcs)},
              {"true_position_mm", tp},
              {"rotation_deg", e.rotation_deg},
              {"rms_mm", e.rms_mm},
              {"points", e.points}};
  CheckPosition(q, tp, q.nominal.feature, &m);
  m.found_mcs = e.top_centre_mcs, m.nominal_mcs = n.top_centre_mcs;
  m.fe.points = e.points;
  m.fe.rms_mm = e.rms_mm;
  m.fe.converged = e.converged;
  return m;
}

// A surface patch against its nominal: the profile (2 max |deviation|) against its tolerance.
// The deviations are the measurement, not fit residuals: the RMS limit does not apply.
Measured Surface(const FeatureRequest& /*request*/,
                 const features::SurfaceNominal& nominal,
                 const Evidence& ev) {
  const features::SurfaceMeasurement s = features::MeasureSurface(ev.points_mcs, nominal);
  Measured m;
  m.size = s.profile_mm;
  // The mean's standard uncertainty: the deviations' scatter about it over the root of their
  // count (k = 1; the points taken as independent, which a probe's neighbours are not quite).
  const double scatter_mm = std::sqrt(std::max(0.0, s.rms_mm * s.rms_mm - s.mean_mm * s.mean_mm));
  m.fields = {{"profile_mm", s.profile_mm},
              {"mean_mm", s.mean_mm},
              {"mean_u_mm", scatter_mm / std::sqrt(static_cast<double>(std::max(1, s.points)))},
              {"min_mm", s.min_mm},
              {"max_mm", s.max_mm},
              {"rms_mm", s.rms_mm},
              {"points", s.points},
              {"coverage", s.coverage},
              {"area_mm2", s.area_mm2}};
  if (nominal.best_fit) {  // the form alone: the points laid on the nominal first
    m.fields["best_fit"] = {{"rotation_rad", JsonVec(s.best_fit.rotation_rad)},
                            {"translation_mm", JsonVec(s.best_fit.translation_mm)},
                            {"about_mm", JsonVec(s.best_fit.about_mcs)},
                            {"iterations", s.best_fit.iterations},
                            {"not_determined", s.best_fit.not_determined}};
    m.fe.converged = s.best_fit.converged;
  }
  m.fe.points = s.points;
  m.fe.area_mm2 = s.area_mm2;
  m.panels = {features::PointsPanel("against the nominal", s.points_mcs, s.deviation_mm,
                                    nominal.normals_mcs.rowwise().sum())};
  return m;
}

// A straight edge from the LED frames (seed 004): where the face meets the wall, against its
// nominal: the offset across it (+: the wall proud) decided on, the angle beside it.
Measured Edge(const FeatureRequest& /*request*/,
              const features::EdgeNominal& n,
              const Evidence& ev) {
  const features::PlaneMeasurement f = features::MeasurePlane(ev.points_mcs, n.face);
  const features::EdgeMeasurement e = features::MeasureEdge(ev.edges, f.plane);
  const features::EdgeDeviation d = features::CompareEdge(e, n, f.height_u_mm);
  Measured m;
  m.size = d.offset_mm;
  m.fields = {{"offset_mm", d.offset_mm},
              {"offset_u_mm", d.offset_u_mm},
              {"angle_deg", d.angle_deg},
              {"angle_u_deg", d.angle_u_deg},
              {"edge",
               {{"point_mm", JsonVec(d.found_mcs)},
                {"direction", JsonVec(e.line_mcs.direction)},
                {"span_mm", e.span_mm},
                {"straightness_mm", e.straightness_mm},
                {"views", e.views},
                {"edge_points", e.points},
                {"rms_px", e.rms_px}}},
              {"face", FaceFields(f)}};
  AddFace(f, &m.fe);
  m.found_mcs = d.found_mcs, m.nominal_mcs = n.point_mcs;
  m.panels = {features::FacePanel("the face", ev.points_mcs, f)};
  return m;
}

// ---- Planning -----------------------------------------------------------------------------

std::vector<features::ViewTarget> Join(std::vector<features::ViewTarget> a,
                                       const std::vector<features::ViewTarget>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

std::vector<features::ViewTarget> PcdViews(const features::PcdNominal& n,
                                           const features::PlanOptions& o) {
  std::vector<features::ViewTarget> views;
  for (size_t k = 0; k < n.holes.size(); ++k)
    views = Join(views, features::BoreViews("hole" + std::to_string(k + 1), n.holes[k], o));
  return views;
}

std::vector<features::ViewTarget> AngleViews(const features::AngleNominal& n,
                                             const features::PlanOptions& o) {
  auto views = features::FaceViews("face", n.face, o);
  return n.datum_face ? Join(views, features::FaceViews("datum", n.datum, o)) : views;
}

// ---- The table ----------------------------------------------------------------------------

using Shape = FeatureNominal::Shape;
struct Feature {
  FeatureTraits traits;
  /// request.nominal -> the typed nominal.
  std::function<Shape(const json& nominal, const std::string& data_dir)> nominal;
  /// The rest of the request -> size, its spec, other tolerances (request->nominal read).
  std::function<void(const json& request, FeatureRequest*)> sizes;
  std::function<Measured(const FeatureRequest&, const Evidence&)> measure;
  std::function<std::vector<features::ViewTarget>(const Shape&, const features::PlanOptions&)>
      views;
};

// One feature's row, written against its own nominal type; Row() stores it behind the variant.
template <class Nominal>
struct TypedFeature {
  FeatureTraits traits;
  std::function<Nominal(const json& nominal, const std::string& data_dir)> nominal;
  std::function<void(const json& request, const Nominal&, FeatureRequest*)> sizes;
  std::function<Measured(const FeatureRequest&, const Nominal&, const Evidence&)> measure;
  std::function<std::vector<features::ViewTarget>(const Nominal&, const features::PlanOptions&)>
      views;
};

template <class Nominal>
Feature Row(TypedFeature<Nominal> t) {
  return {t.traits,
          [p = t.nominal](const json& j, const std::string& dir) -> Shape { return p(j, dir); },
          [s = t.sizes](const json& r, FeatureRequest* q) {
            s(r, std::get<Nominal>(q->nominal.shape), q);
          },
          [m = t.measure](const FeatureRequest& q, const Evidence& ev) {
            return m(q, std::get<Nominal>(q.nominal.shape), ev);
          },
          [v = t.views](const Shape& s, const features::PlanOptions& o) {
            return v(std::get<Nominal>(s), o);
          }};
}

// Traits: the offset a size error moves, per unit of error (a bore 6 um small: its radius
// offset drops 3 um; a boss, a web the other way; a face proud by e: the tool is e shorter
// than its offset says).
FeatureTraits Traits(std::string size_name,
                     std::optional<double> change_per_error,
                     bool moves_length,
                     bool has_position,
                     std::string unit = "mm") {
  return {std::move(size_name), std::move(unit), change_per_error, moves_length, has_position};
}

using O = features::PlanOptions;

Feature Cylinder(bool boss) {
  const char* functional = boss ? "mcc" : "mic";
  return Row<features::BoreNominal>(
      {Traits("diameter", boss ? -0.5 : 0.5, false, true),
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
       },
       Cylindrical,
       [](const features::BoreNominal& n, const O& o) {
         return features::BoreViews("wall", n, o);
       }});
}

Feature FaceFeature() {
  return Row<features::PlaneNominal>(
      {Traits("height", -1.0, true, true),
       [](const json& j, const std::string&) { return ParsePlaneNominal(j, kNom); },
       [](const json& r, const features::PlaneNominal&, FeatureRequest* q) {
         q->spec = Spec(r, "tolerance", 0.0, "mm");
         q->flatness_tol_mm = OptionalNumber(r, "flatness_tol_mm");
       },
       Face,
       [](const features::PlaneNominal& n, const O& o) {
         return features::FaceViews("face", n, o);
       }});
}

Feature WidthFeature(bool inside) {
  return Row<features::WidthNominal>(
      {Traits("width", inside ? 0.5 : -0.5, false, true),  // the side cutter's radius
       [inside](const json& j, const std::string&) { return ParseWidth(j, inside); },
       [](const json& r, const features::WidthNominal& n, FeatureRequest* q) {
         q->spec = Spec(r, "tolerance", n.width_mm, "mm");
       },
       Width, features::WidthViews});
}

Feature RectangleFeature(bool inside) {
  return Row<features::RectangleNominal>(
      {Traits("size", inside ? 0.5 : -0.5, false, true),
       [inside](const json& j, const std::string&) { return ParseRectangle(j, inside); },
       [](const json& r, const features::RectangleNominal& n, FeatureRequest* q) {
         q->size = SizeChoice(r, {"x", "y"}, "x or y");
         const bool x = q->size == "x";
         q->spec = Spec(r, "tolerance", x ? n.size_x_mm : n.size_y_mm, "mm");
         q->other_spec = Spec(r, r.contains("tolerance_y") ? "tolerance_y" : "tolerance",
                              x ? n.size_y_mm : n.size_x_mm, "mm");
         q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
       },
       Rectangle, features::RectangleViews});
}

// A step and an angle: their size's nominal is a field of the nominal no jobs type holds.
Feature StepFeature() {
  return Row<features::StepNominal>(
      {Traits("height", -1.0, true, false),  // face B cut by the tool to correct
       [](const json& j, const std::string&) { return ParseStep(j); },
       [](const json& r, const features::StepNominal&, FeatureRequest* q) {
         const double height_mm = jf::Number<JobInputError>(Nominal(r), "height_mm", kNom);
         q->spec = Spec(r, "tolerance", height_mm, "mm");
       },
       Step,
       [](const features::StepNominal& n, const O& o) {
         return Join(features::FaceViews("face_a", n.a, o), features::FaceViews("face_b", n.b, o));
       }});
}

Feature AngleFeature() {
  return Row<features::AngleNominal>(
      {Traits("angle", std::nullopt, false, false, "deg"),
       [](const json& j, const std::string&) { return ParseAngle(j); },
       [](const json& r, const features::AngleNominal&, FeatureRequest* q) {
         const double angle_deg = jf::Number<JobInputError>(Nominal(r), "angle_deg", kNom);
         q->spec = Spec(r, "tolerance", angle_deg, "deg");
       },
       Angle, AngleViews});
}

Feature PcdFeature() {
  return Row<features::PcdNominal>(
      {Traits("diameter", std::nullopt, false, true),
       [](const json& j, const std::string&) { return ParsePcd(j); },
       [](const json& r, const features::PcdNominal& n, FeatureRequest* q) {
         q->spec = Spec(r, "tolerance", n.diameter_mm, "mm");
         q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
       },
       Pcd, PcdViews});
}

Feature EllipseFeature(bool inside) {
  return Row<features::EllipseNominal>(
      {Traits("diameter", inside ? 0.5 : -0.5, false, true),
       [inside](const json& j, const std::string&) { return ParseEllipse(j, inside); },
       [](const json& r, const features::EllipseNominal& n, FeatureRequest* q) {
         q->size = SizeChoice(r, {"major", "minor"}, "major or minor");
         q->spec = Spec(r, "tolerance", q->size == "major" ? n.major_mm : n.minor_mm, "mm");
         q->position_tol_mm = OptionalNumber(r, "position_tol_mm");
       },
       Ellipse, features::EllipseViews});
}

Feature SurfaceFeature() {
  return Row<features::SurfaceNominal>(
      {Traits("profile", std::nullopt, false, false), SurfaceNominalOf,
       [](const json& r, const features::SurfaceNominal&, FeatureRequest* q) {
         q->spec = {0.0, jf::Number<JobInputError>(r, "profile_tol_mm", "request"), 0.0};
       },
       Surface, features::SurfaceViews});
}

Feature EdgeFeature() {
  return Row<features::EdgeNominal>(
      {Traits("offset", -1.0, false, false),  // a wall proud by e: the side cutter's radius -e
       [](const json& j, const std::string&) { return ParseEdge(j); },
       [](const json& r, const features::EdgeNominal&, FeatureRequest* q) {
         q->spec = Spec(r, "tolerance", 0.0, "mm");
       },
       Edge,
       [](const features::EdgeNominal& n, const O& o) {
         return features::EdgeViews("edge", n, o);
       }});
}

const std::map<std::string, Feature>& Features() {
  static const std::map<std::string, Feature> features = {
      {"bore", Cylinder(false)},
      {"boss", Cylinder(true)},
      {"face", FaceFeature()},
      {"pocket_width", WidthFeature(true)},
      {"web_width", WidthFeature(false)},
      {"rect_pocket", RectangleFeature(true)},
      {"rect_boss", RectangleFeature(false)},
      {"step", StepFeature()},
      {"angle", AngleFeature()},
      {"pcd", PcdFeature()},
      {"ellipse_bore", EllipseFeature(true)},
      {"ellipse_boss", EllipseFeature(false)},
      {"surface", SurfaceFeature()},
      {"edge", EdgeFeature()},
  };
  return features;
}

// Throws JobInputError listing the features known when `feature` is not one of them.
const Feature& FeatureNamed(const std::string& feature) {
  const auto it = Features().find(feature);
  if (it != Features().end()) return it->second;
  std::string known;
  for (const auto& [name, f] : Features()) known += (known.empty() ? "" : ", ") + name;
  throw JobInputError("request.feature \"" + feature + "\" is not one of " + known);
}

}  // namespace

FeatureNominal ParseFeatureNominal(const json& r, const std::string& data_dir) {
  FeatureNominal n;
  n.feature = jf::Text<JobInputError>(r, "feature", "request");
  n.shape = FeatureNamed(n.feature).nominal(Nominal(r), data_dir);
  return n;
}

FeatureRequest ParseFeatureRequest(const json& r, const std::string& data_dir) {
  FeatureRequest q;
  q.nominal = ParseFeatureNominal(r, data_dir);
  const Feature& f = FeatureNamed(q.nominal.feature);
  q.traits = f.traits;
  f.sizes(r, &q);
  return q;
}

Measured MeasureFeature(const FeatureRequest& q, const Evidence& ev) {
  Measured m = FeatureNamed(q.nominal.feature).measure(q, ev);
  m.feature = q.nominal.feature;
  m.traits = q.traits;
  m.spec = q.spec;
  return m;
}

std::vector<features::ViewTarget> FeatureViews(const FeatureNominal& n,
                                               const features::PlanOptions& options) {
  return FeatureNamed(n.feature).views(n.shape, options);
}

}  // namespace mlp::service
