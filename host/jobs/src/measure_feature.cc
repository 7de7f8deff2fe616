#include "mlp/jobs/measure_feature.h"

#include "mlp/base/check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>

namespace mlp::jobs {
namespace {

using geometry::Vec3;

std::string Um(double mm) {
  char s[32];
  std::snprintf(s, sizeof s, "%.1f um", mm * 1e3);
  return s;
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

Readings FaceReadings(const features::PlaneMeasurement& f) {
  return {{"normal", Vec3(f.plane.normal)},
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
  m.readings = Readings{{"diameter_mm", b.diameter_mm},
                        {"diameter_u_mm", b.diameter_u_mm},
                        {n.boss ? "diameter_mcc_mm" : "diameter_mic_mm", b.functional_diameter_mm},
                        {"centre_mm", Vec3(b.top_centre_mcs)},
                        {"true_position_mm", tp},
                        {"rms_mm", b.rms_mm},
                        {"points", b.points},
                        {"arc_span_deg", b.arc_span_deg}};
  CheckPosition(q, tp, q.nominal.feature, &m);
  if (n.cylindricity) {
    Set(&m.readings, {"cylindricity_mm", b.cylindricity_mm});
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
  m.readings = FaceReadings(f);
  Set(&m.readings, {"flatness_mm", f.flatness_mm});
  Set(&m.readings, {"trimmed", f.trimmed});
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
  m.readings = Readings{{"width_mm", w.width_mm},
                        {"width_u_mm", w.width_u_mm},
                        {"centre_mm", Vec3(w.centre_mcs)},
                        {"parallelism_deg", w.parallelism_deg},
                        {"face_plus", FaceReadings(w.plus)},
                        {"face_minus", FaceReadings(w.minus)}};
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
  m.readings = Readings{{"size_x_mm", rect.x.width_mm},       {"size_x_u_mm", rect.x.width_u_mm},
                        {"size_y_mm", rect.y.width_mm},       {"size_y_u_mm", rect.y.width_u_mm},
                        {"centre_mm", Vec3(rect.centre_mcs)}, {"true_position_mm", tp},
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
  m.readings = Readings{{"height_mm", s.height_mm},
                        {"height_u_mm", s.height_u_mm},
                        {"parallelism_deg", s.parallelism_deg},
                        {"face_a", FaceReadings(s.a)},
                        {"face_b", FaceReadings(s.b)}};
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
  m.readings = Readings{{"angle_deg", a.angle_deg},
                        {"angle_u_deg", a.angle_u_deg},
                        {"skew_deg", a.skew_deg},
                        {"face", FaceReadings(a.face)}};
  AddFace(a.face, &m.fe);
  m.panels = {features::FacePanel("the face", ev.points_mcs, a.face)};
  if (n.datum_face) {
    Set(&m.readings, {"datum", FaceReadings(a.datum)});
    AddFace(a.datum, &m.fe);
    m.panels.push_back(features::FacePanel("the datum", ev.points_mcs, a.datum));
  }
  return m;
}

Measured Pcd(const FeatureRequest& q, const features::PcdNominal& n, const Evidence& ev) {
  const features::PcdMeasurement p = features::MeasurePcd(ev.points_mcs, n);
  Measured m;
  m.size = p.diameter_mm;
  std::vector<Readings> holes;
  m.fe.arc_span_deg = 360.0;
  m.fe.converged = p.converged;
  for (size_t k = 0; k < p.holes.size(); ++k) {
    const features::BoreMeasurement& h = p.holes[k];
    holes.push_back(Readings{{"centre_mm", Vec3(h.top_centre_mcs)},
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
  m.readings = Readings{{"diameter_mm", p.diameter_mm},    {"diameter_u_mm", p.diameter_u_mm},
                        {"centre_mm", Vec3(p.centre_mcs)}, {"rotation_deg", p.rotation_deg},
                        {"centres_rms_mm", p.rms_mm},      {"holes", holes}};
  return m;
}

Measured Ellipse(const FeatureRequest& q, const features::EllipseNominal& n, const Evidence& ev) {
  const features::EllipseMeasurement e = features::MeasureEllipse(ev.points_mcs, n);
  Measured m;
  m.size = q.size == "major" ? e.major_mm : e.minor_mm;
  const double tp = TruePosition(e.top_centre_mcs, n.top_centre_mcs, n.axis_mcs);
  m.readings = Readings{{"major_mm", e.major_mm},
                        {"major_u_mm", e.major_u_mm},
                        {"minor_mm", e.minor_mm},
                        {"minor_u_mm", e.minor_u_mm},
                        {"centre_mm", Vec3(e.top_centre_mcs)},
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
  m.readings =
      Readings{{"profile_mm", s.profile_mm},
               {"mean_mm", s.mean_mm},
               {"mean_u_mm", scatter_mm / std::sqrt(static_cast<double>(std::max(1, s.points)))},
               {"min_mm", s.min_mm},
               {"max_mm", s.max_mm},
               {"rms_mm", s.rms_mm},
               {"points", s.points},
               {"coverage", s.coverage},
               {"area_mm2", s.area_mm2}};
  if (nominal.best_fit) {  // the form alone: the points laid on the nominal first
    Set(&m.readings, {"best_fit", Readings{{"rotation_rad", Vec3(s.best_fit.rotation_rad)},
                                           {"translation_mm", Vec3(s.best_fit.translation_mm)},
                                           {"about_mm", Vec3(s.best_fit.about_mcs)},
                                           {"iterations", s.best_fit.iterations},
                                           {"not_determined", s.best_fit.not_determined}}});
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
  m.readings = Readings{{"offset_mm", d.offset_mm},
                        {"offset_u_mm", d.offset_u_mm},
                        {"angle_deg", d.angle_deg},
                        {"angle_u_deg", d.angle_u_deg},
                        {"edge", Readings{{"point_mm", Vec3(d.found_mcs)},
                                          {"direction", Vec3(e.line_mcs.direction)},
                                          {"span_mm", e.span_mm},
                                          {"straightness_mm", e.straightness_mm},
                                          {"views", e.views},
                                          {"edge_points", e.points},
                                          {"rms_px", e.rms_px}}},
                        {"face", FaceReadings(f)}};
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
using O = features::PlanOptions;

struct Feature {
  FeatureTraits traits;
  std::function<Measured(const FeatureRequest&, const Evidence&)> measure;
  std::function<std::vector<features::ViewTarget>(const Shape&, const O&)> views;
};

// One feature's row, written against its own nominal type; Row() stores it behind the variant.
template <class Nominal>
Feature Row(FeatureTraits traits,
            Measured (*measure)(const FeatureRequest&, const Nominal&, const Evidence&),
            std::function<std::vector<features::ViewTarget>(const Nominal&, const O&)> views) {
  return {
      std::move(traits),
      [measure](const FeatureRequest& q, const Evidence& ev) {
        return measure(q, std::get<Nominal>(q.nominal.shape), ev);
      },
      [v = std::move(views)](const Shape& s, const O& o) { return v(std::get<Nominal>(s), o); }};
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

Feature Cylinder(bool boss) {
  return Row<features::BoreNominal>(
      Traits("diameter", boss ? -0.5 : 0.5, false, true), Cylindrical,
      [](const features::BoreNominal& n, const O& o) { return features::BoreViews("wall", n, o); });
}

Feature FaceFeature() {
  return Row<features::PlaneNominal>(Traits("height", -1.0, true, true), Face,
                                     [](const features::PlaneNominal& n, const O& o) {
                                       return features::FaceViews("face", n, o);
                                     });
}

// A step's face B is cut by the tool to correct; an edge's wall proud by e: the side cutter's
// radius -e; a width across: the side cutter's radius.
const std::map<std::string, Feature>& Features() {
  static const std::map<std::string, Feature> table = {
      {"bore", Cylinder(false)},
      {"boss", Cylinder(true)},
      {"face", FaceFeature()},
      {"pocket_width",
       Row<features::WidthNominal>(Traits("width", 0.5, false, true), Width, features::WidthViews)},
      {"web_width", Row<features::WidthNominal>(Traits("width", -0.5, false, true), Width,
                                                features::WidthViews)},
      {"rect_pocket", Row<features::RectangleNominal>(Traits("size", 0.5, false, true), Rectangle,
                                                      features::RectangleViews)},
      {"rect_boss", Row<features::RectangleNominal>(Traits("size", -0.5, false, true), Rectangle,
                                                    features::RectangleViews)},
      {"step", Row<features::StepNominal>(Traits("height", -1.0, true, false), Step,
                                          [](const features::StepNominal& n, const O& o) {
                                            return Join(features::FaceViews("face_a", n.a, o),
                                                        features::FaceViews("face_b", n.b, o));
                                          })},
      {"angle", Row<features::AngleNominal>(Traits("angle", std::nullopt, false, false, "deg"),
                                            Angle, AngleViews)},
      {"pcd",
       Row<features::PcdNominal>(Traits("diameter", std::nullopt, false, true), Pcd, PcdViews)},
      {"ellipse_bore", Row<features::EllipseNominal>(Traits("diameter", 0.5, false, true), Ellipse,
                                                     features::EllipseViews)},
      {"ellipse_boss", Row<features::EllipseNominal>(Traits("diameter", -0.5, false, true), Ellipse,
                                                     features::EllipseViews)},
      {"surface", Row<features::SurfaceNominal>(Traits("profile", std::nullopt, false, false),
                                                Surface, features::SurfaceViews)},
      {"edge", Row<features::EdgeNominal>(Traits("offset", -1.0, false, false), Edge,
                                          [](const features::EdgeNominal& n, const O& o) {
                                            return features::EdgeViews("edge", n, o);
                                          })},
  };
  return table;
}

// A feature the service did not read from a known name is a programming error.
const Feature& FeatureNamed(const std::string& feature) {
  const auto it = Features().find(feature);
  MLP_CHECK(it != Features().end());
  return it->second;
}

}  // namespace

std::vector<std::string> FeatureNames() {
  std::vector<std::string> names;
  names.reserve(Features().size());
  for (const auto& [name, f] : Features()) names.push_back(name);
  return names;
}

std::optional<FeatureTraits> TraitsOf(const std::string& feature) {
  const auto it = Features().find(feature);
  if (it == Features().end()) return std::nullopt;
  return it->second.traits;
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

}  // namespace mlp::jobs
