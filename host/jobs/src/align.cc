#include "mlp/jobs/align.h"

#include "mlp/base/check.h"

#include <algorithm>
#include <cmath>

namespace mlp::jobs {
namespace {

using geometry::Plane;
using geometry::Vec3;

// The frame found so far, with what the gate weighs and the readings of its features.
struct Datum {
  features::FitEvidence fe;
  std::string probe;  ///< the probe of the last face measured
  Readings readings;
};

features::PlaneMeasurement MeasureFace(const FaceInput& f, Datum* d) {
  d->probe = f.evidence.probe_serial;
  return features::MeasurePlane(f.evidence.points_mcs, f.nominal);
}

// Where a bore's fitted axis meets the plane.
Vec3 AxisOnPlane(const features::BoreMeasurement& b, const Plane& a) {
  const double t = (a.point - b.top_centre_mcs).dot(a.normal) / b.axis_mcs.dot(a.normal);
  return b.top_centre_mcs + t * b.axis_mcs;
}

// The line where two planes meet.
geometry::Line3 Intersection(const Plane& a, const Plane& b) {
  geometry::Line3 l;
  l.direction = a.normal.cross(b.normal).normalized();
  // The point on both planes closest to a's point.
  Eigen::Matrix3d m;
  m.row(0) = a.normal.transpose();
  m.row(1) = b.normal.transpose();
  m.row(2) = l.direction.transpose();
  l.point = m.colPivHouseholderQr().solve(
      Vec3(a.normal.dot(a.point), b.normal.dot(b.point), l.direction.dot(a.point)));
  return l;
}

// A hole measured as a bore: its fitted axis where it meets plane A; the gate's evidence and
// the readings for it under `name`.
Vec3 HoleOnPlane(const HoleInput& h,
                 const std::string& name,
                 const features::PlaneMeasurement& a,
                 Datum* d) {
  const features::BoreMeasurement b = features::MeasureBore(h.evidence.points_mcs, h.nominal);
  Vec3 centre = AxisOnPlane(b, a.plane);
  d->fe.arc_span_deg = std::min(d->fe.arc_span_deg.value_or(360.0), b.arc_span_deg);
  d->fe.rms_mm = std::max(d->fe.rms_mm, b.rms_mm);
  d->fe.points = std::min(d->fe.points, b.points);
  d->fe.converged = d->fe.converged && b.converged;
  Set(&d->readings, {name, Readings{{"centre_mm", centre},
                                    {"diameter_mm", b.diameter_mm},
                                    {"rms_mm", b.rms_mm},
                                    {"points", b.points},
                                    {"arc_span_deg", b.arc_span_deg}}});
  return centre;
}

// A part edge on plane A from the LED frames; its readings under `name`.
features::EdgeMeasurement EdgeOnA(const EdgeInput& in,
                                  const std::string& name,
                                  const features::PlaneMeasurement& a,
                                  Datum* d) {
  features::EdgeMeasurement e = features::MeasureEdge(in.evidence.edges, a.plane);
  Set(&d->readings, {name, Readings{{"point_mm", Vec3(e.line_mcs.point)},
                                    {"direction", Vec3(e.line_mcs.direction)},
                                    {"span_mm", e.span_mm},
                                    {"straightness_mm", e.straightness_mm},
                                    {"views", e.views},
                                    {"edge_points", e.points},
                                    {"rms_px", e.rms_px}}});
  return e;
}

// A further face (B or C): its fit counts in the gate; its readings under `name`.
features::PlaneMeasurement OtherFace(const FaceInput& f, const std::string& name, Datum* d) {
  features::PlaneMeasurement m = MeasureFace(f, d);
  d->fe.rms_mm = std::max(d->fe.rms_mm, m.rms_mm);
  d->fe.points = std::min(d->fe.points, m.points);
  Set(&d->readings, {name, Readings{{"normal", Vec3(m.plane.normal)}, {"rms_mm", m.rms_mm}}});
  return m;
}

// The secondary line (seed 004's "line", its two touch points).
geometry::Line3 SecondaryLine(const AlignInputs& in,
                              const features::PlaneMeasurement& a,
                              Datum* d) {
  if (const auto* b = std::get_if<FaceInput>(&in.line_b))
    return Intersection(a.plane, OtherFace(*b, "plane_b", d).plane);
  if (const auto* e = std::get_if<EdgeInput>(&in.line_b))
    return EdgeOnA(*e, "line_b", a, d).line_mcs;
  if (const auto* t = std::get_if<TouchPoints>(&in.line_b)) {
    if (!((t->q - t->p).norm() >= kMinTouchSpanMm))
      throw RequestError("request.line_b: the two points must be at least 5 mm apart");
    Set(&d->readings, {"line_b", Readings{{"points_mm", std::vector<Vec3>{t->p, t->q}},
                                          {"span_mm", (t->q - t->p).norm()}}});
    return {t->p, (t->q - t->p).normalized()};
  }
  throw RequestError("request (plane_b or line_b): plane-line-point needs a secondary line");
}

// Where two lines on plane A cross (the midpoint of their closest points).
Vec3 Crossing(const geometry::Line3& b, const geometry::Line3& c) {
  // Edges closer than 10 deg to parallel make a corner of their scatter.
  constexpr double kMinSin = 0.17;
  const Vec3 n = b.direction.cross(c.direction);
  if (!(n.norm() > kMinSin))
    throw RequestError("request.edge_c runs within 10 deg of the line: it makes no corner");
  const double tb = (c.point - b.point).cross(c.direction).dot(n) / n.squaredNorm();
  const double tc = (c.point - b.point).cross(b.direction).dot(n) / n.squaredNorm();
  return 0.5 * (b.point + tb * b.direction + c.point + tc * c.direction);
}

// Where the line meets face C.
Vec3 LineOnFace(const geometry::Line3& line, const features::PlaneMeasurement& c) {
  const double along = line.direction.dot(c.plane.normal);
  if (!(std::abs(along) > 1e-6))
    throw RequestError("request.plane_c runs along the line: it cannot fix the origin");
  return line.point + line.direction * ((c.plane.point - line.point).dot(c.plane.normal) / along);
}

// The tertiary point (seed 004's "point").
Vec3 TertiaryPoint(const AlignInputs& in,
                   const features::PlaneMeasurement& a,
                   const geometry::Line3& line,
                   Datum* d) {
  if (const auto* c = std::get_if<FaceInput>(&in.point_c))
    return LineOnFace(line, OtherFace(*c, "plane_c", d));
  if (const auto* h = std::get_if<HoleInput>(&in.point_c)) return HoleOnPlane(*h, "hole_c", a, d);
  if (const auto* e = std::get_if<EdgeInput>(&in.point_c)) {
    const features::EdgeMeasurement edge = EdgeOnA(*e, "edge_c", a, d);
    Vec3 corner = Crossing(line, edge.line_mcs);
    Set(&std::get<Readings>(Find(&d->readings, "edge_c")->value), {"corner_mm", corner});
    return corner;
  }
  if (const auto* p = std::get_if<GivenPoint>(&in.point_c)) {
    Set(&d->readings, {"point_c", Readings{{"point_mm", p->point_mcs}}});
    return p->point_mcs;
  }
  throw RequestError(
      "request (plane_c, hole_c, edge_c or point_c): plane-line-point needs a tertiary point");
}

}  // namespace

AlignOutcome AssessAlign(const AlignInputs& in,
                         const CalibrationFacts& calibration,
                         const features::PlausibilityLimits& limits) {
  Datum d;
  const features::PlaneMeasurement a = MeasureFace(in.plane_a, &d);
  d.fe.points = a.points;
  d.fe.rms_mm = a.rms_mm;
  Set(&d.readings,
      {"plane_a",
       Readings{{"normal", Vec3(a.plane.normal)}, {"rms_mm", a.rms_mm}, {"points", a.points}}});
  AlignOutcome o;
  if (in.method == "plane-circle-circle") {
    if (!in.circle_b || !in.circle_c)
      throw RequestError("request: plane-circle-circle needs circle_b and circle_c");
    const Vec3 b = HoleOnPlane(*in.circle_b, "circle_b", a, &d);
    const Vec3 c = HoleOnPlane(*in.circle_c, "circle_c", a, &d);
    o.mcs_from_work = geometry::DatumPlaneCircleCircle(a.plane, b, c);
  } else {
    const geometry::Line3 line = SecondaryLine(in, a, &d);
    const Vec3 point = TertiaryPoint(in, a, line, &d);
    o.mcs_from_work = geometry::DatumPlaneLinePoint(a.plane, line, point);
  }
  o.work = geometry::ReadWorkOffset(o.mcs_from_work);
  d.fe.calibration_probe = calibration.probe_serial;
  d.fe.job_probe = d.probe;
  d.fe.calibration_age_h = calibration.age_h;
  d.fe.tilt_deg = o.work.tilt_deg;
  if (in.expected_origin_mm)
    d.fe.work_shift_mm = (o.work.origin_mm - *in.expected_origin_mm).norm();
  o.refusal = features::PlausibilityProblems(d.fe, limits);
  o.readings = std::move(d.readings);
  o.fe = d.fe;
  return o;
}

nc::NcResult AlignChanges(const AlignOutcome& o,
                          const AlignInputs& in,
                          std::int64_t job,
                          bool named_parameters) {
  MLP_CHECK(o.refusal.empty());  // the gate refused: nothing goes to the machine
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": " + in.method + " alignment";
  nc::WorkOffsetChange w;
  w.index = in.work_offset;
  for (int k = 0; k < 3; ++k) w.after_mm[k] = o.work.origin_mm(k);
  w.rotation_after_deg = o.work.rotation_z_deg;
  out.work.push_back(w);
  if (named_parameters) out.named = {{"status", 0.0}, {"rotation", o.work.rotation_z_deg}};
  return out;
}

}  // namespace mlp::jobs
