#include "mlp/base/clock.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/features/decision.h"
#include "mlp/geometry/datum.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;
using geometry::Plane;
using geometry::Vec3;

// A face from the captures, segmented by its nominal (features::MeasurePlane).
features::PlaneMeasurement MeasureFace(JobContext& ctx,
                                       const json& f,
                                       const std::string& w,
                                       const geometry::Pose3& m,
                                       std::int64_t job,
                                       std::string* probe) {
  const json& n = jf::Object<JobInputError>(f, "nominal", w);
  const features::PlaneNominal nominal = ParsePlaneNominal(n, w + ".nominal");
  if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
  const Evidence ev = LoadCaptures(ctx, f.at("captures"), m, job);
  *probe = ev.probe_serial;
  return features::MeasurePlane(ev.points_mcs, nominal);
}

// Where a bore's fitted axis meets the plane.
Vec3 AxisOnPlane(const features::BoreMeasurement& b, const Plane& a) {
  const double t = (a.point - b.top_centre_mcs).dot(a.normal) / b.axis_mcs.dot(a.normal);
  return b.top_centre_mcs + t * b.axis_mcs;
}

// The line where two planes meet, directed along the second plane's `direction` hint.
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

// What an align request asks for, read once before any capture is loaded.
struct AlignRequest {
  std::string method;  ///< plane-circle-circle, plane-line-point, plane-plane-plane
  int work_offset = 0;
  std::optional<Vec3> expected_origin_mm;
};

AlignRequest ParseAlignRequest(const json& r) {
  AlignRequest a;
  a.method = jf::Text<JobInputError>(r, "method", "request");
  if (a.method != "plane-circle-circle" && a.method != "plane-line-point" &&
      a.method != "plane-plane-plane")
    throw JobInputError(
        "method must be plane-circle-circle, plane-line-point or plane-plane-plane");
  a.work_offset = jf::Integer<JobInputError>(r, "work_offset", "request");
  if (r.contains("expected_origin_mm"))
    a.expected_origin_mm = jf::Vector3<JobInputError>(r, "expected_origin_mm", "request");
  return a;
}

// The datum frame found, with what the gate weighs and what the reply says of its features.
struct Datum {
  geometry::Pose3 mcs_from_work = geometry::Pose3::Identity();
  features::FitEvidence fe;
  std::string probe;
  json fields;
};

// The captures request.NAME.KEY lists (capture jobs), loaded into the machine frame.
Evidence NamedCaptures(JobContext& ctx,
                       const json& r,
                       const char* name,
                       const char* key,
                       const geometry::Pose3& m,
                       std::int64_t job) {
  const std::string w = std::string("request.") + name + "." + key;
  const json& f = jf::Object<JobInputError>(r, name, "request");
  if (!f.contains(key)) throw JobInputError(w + " must list capture jobs");
  return LoadCaptures(ctx, f.at(key), m, job);
}

// A hole measured as a bore (request.NAME: captures and nominal): its fitted axis where it
// meets plane A; the gate's evidence and the reply's fields for it.
Vec3 HoleOnPlane(JobContext& ctx,
                 const json& r,
                 const char* name,
                 const geometry::Pose3& m,
                 std::int64_t job,
                 const features::PlaneMeasurement& a,
                 Datum* d) {
  const std::string w = std::string("request.") + name;
  const Evidence ev = NamedCaptures(ctx, r, name, "captures", m, job);
  const json& n = jf::Object<JobInputError>(r.at(name), "nominal", w);
  const features::BoreMeasurement b =
      features::MeasureBore(ev.points_mcs, ParseBoreNominal(n, w + ".nominal"));
  Vec3 centre = AxisOnPlane(b, a.plane);
  d->fe.arc_span_deg = std::min(d->fe.arc_span_deg.value_or(360.0), b.arc_span_deg);
  d->fe.rms_mm = std::max(d->fe.rms_mm, b.rms_mm);
  d->fe.points = std::min(d->fe.points, b.points);
  d->fe.converged = d->fe.converged && b.converged;
  d->fields[name] = {{"centre_mm", JsonVec(centre)},
                     {"diameter_mm", b.diameter_mm},
                     {"rms_mm", b.rms_mm},
                     {"points", b.points},
                     {"arc_span_deg", b.arc_span_deg}};
  return centre;
}

// Plane A, then the two bores' axes where they meet it: the origin at the first, X towards
// the second.
void PlaneCircleCircle(JobContext& ctx,
                       const json& r,
                       const geometry::Pose3& m,
                       std::int64_t job,
                       const features::PlaneMeasurement& a,
                       Datum* d) {
  const Vec3 b = HoleOnPlane(ctx, r, "circle_b", m, job, a, d);
  const Vec3 c = HoleOnPlane(ctx, r, "circle_c", m, job, a, d);
  d->mcs_from_work = geometry::DatumPlaneCircleCircle(a.plane, b, c);
}

// One point of a list: [x, y, z] in mm, finite.
Vec3 ListedPoint(const json& e, const std::string& where) {
  if (!e.is_array() || e.size() != 3 ||
      !std::all_of(e.begin(), e.end(), [](const json& x) { return x.is_number(); }))
    throw JobInputError(where + " must be [x, y, z] in mm");
  Vec3 v(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
  if (!v.allFinite()) throw JobInputError(where + " must be finite");
  return v;
}

// A part edge on plane A from the LED frames of edge captures (request.NAME.edges: capture jobs
// taken with an "edge:x,y" ROI, e.g. from a plan of an "edge" feature); its fields in the reply.
features::EdgeMeasurement EdgeOnA(JobContext& ctx,
                                  const json& r,
                                  const char* name,
                                  const geometry::Pose3& m,
                                  std::int64_t job,
                                  const features::PlaneMeasurement& a,
                                  Datum* d) {
  const Evidence ev = NamedCaptures(ctx, r, name, "edges", m, job);
  if (ev.edges.size() != r.at(name).at("edges").size())
    throw JobInputError(std::string("request.") + name +
                        ".edges: a capture holds no edge (take it with an edge:x,y ROI)");
  features::EdgeMeasurement e = features::MeasureEdge(ev.edges, a.plane);
  d->fields[name] = {{"point_mm", JsonVec(e.line_mcs.point)},
                     {"direction", JsonVec(e.line_mcs.direction)},
                     {"span_mm", e.span_mm},
                     {"straightness_mm", e.straightness_mm},
                     {"views", e.views},
                     {"edge_points", e.points},
                     {"rms_px", e.rms_px}};
  return e;
}

// The secondary line (seed 004's "line", its two touch points): face B's trace on A
// ("plane_b": a line probe takes the whole face), or a part edge measured as two points on it
// ("line_b": {"points_mm": [p, q]}, machine coordinates, from the controller's touch probe or a
// measured edge; p -> q is X), or the edge in the LED frames ("line_b": {"edges": [captures]};
// X runs with the part on +Y).
geometry::Line3 SecondaryLine(JobContext& ctx,
                              const json& r,
                              const geometry::Pose3& m,
                              std::int64_t job,
                              const features::PlaneMeasurement& a,
                              Datum* d) {
  if (r.contains("plane_b")) {
    const features::PlaneMeasurement b =
        MeasureFace(ctx, r.at("plane_b"), "request.plane_b", m, job, &d->probe);
    d->fe.rms_mm = std::max(d->fe.rms_mm, b.rms_mm);
    d->fe.points = std::min(d->fe.points, b.points);
    d->fields["plane_b"] = {{"normal", JsonVec(b.plane.normal)}, {"rms_mm", b.rms_mm}};
    return Intersection(a.plane, b.plane);
  }
  const json& l = jf::Object<JobInputError>(r, "line_b", "request (plane_b or line_b)");
  if (l.contains("edges")) return EdgeOnA(ctx, r, "line_b", m, job, a, d).line_mcs;
  if (!l.contains("points_mm") || !l.at("points_mm").is_array() || l.at("points_mm").size() != 2)
    throw JobInputError(
        "request.line_b must hold edges (edge captures) or points_mm (two points [x, y, z])");
  const Vec3 p = ListedPoint(l.at("points_mm")[0], "request.line_b.points_mm[0]");
  const Vec3 q = ListedPoint(l.at("points_mm")[1], "request.line_b.points_mm[1]");
  // Two touch points closer than this make X from their scatter, not from the edge.
  constexpr double kMinSpanMm = 5.0;
  if (!((q - p).norm() >= kMinSpanMm))
    throw JobInputError("request.line_b: the two points must be at least 5 mm apart");
  d->fields["line_b"] = {{"points_mm", l.at("points_mm")}, {"span_mm", (q - p).norm()}};
  return {p, (q - p).normalized()};
}

// Where two lines on plane A cross (the midpoint of their closest points).
Vec3 Crossing(const geometry::Line3& b, const geometry::Line3& c) {
  // Edges closer than 10 deg to parallel make a corner of their scatter.
  constexpr double kMinSin = 0.17;
  const Vec3 n = b.direction.cross(c.direction);
  if (!(n.norm() > kMinSin))
    throw JobInputError("request.edge_c runs within 10 deg of the line: it makes no corner");
  const double tb = (c.point - b.point).cross(c.direction).dot(n) / n.squaredNorm();
  const double tc = (c.point - b.point).cross(b.direction).dot(n) / n.squaredNorm();
  return 0.5 * (b.point + tb * b.direction + c.point + tc * c.direction);
}

// The tertiary point (seed 004's "point"): face C ("plane_c": where the line meets it), a hole
// ("hole_c": its fitted axis on A, measured as a bore), a corner ("edge_c": {"edges": [edge
// captures]}, where that edge meets the line), or a point ("point_c": {"point_mm"}).
Vec3 TertiaryPoint(JobContext& ctx,
                   const json& r,
                   const geometry::Pose3& m,
                   std::int64_t job,
                   const features::PlaneMeasurement& a,
                   const geometry::Line3& line,
                   Datum* d) {
  if (r.contains("plane_c")) {
    const features::PlaneMeasurement c =
        MeasureFace(ctx, r.at("plane_c"), "request.plane_c", m, job, &d->probe);
    d->fe.rms_mm = std::max(d->fe.rms_mm, c.rms_mm);
    d->fe.points = std::min(d->fe.points, c.points);
    d->fields["plane_c"] = {{"normal", JsonVec(c.plane.normal)}, {"rms_mm", c.rms_mm}};
    const double along = line.direction.dot(c.plane.normal);
    if (!(std::abs(along) > 1e-6))
      throw JobInputError("request.plane_c runs along the line: it cannot fix the origin");
    return line.point + line.direction * ((c.plane.point - line.point).dot(c.plane.normal) / along);
  }
  if (r.contains("hole_c")) return HoleOnPlane(ctx, r, "hole_c", m, job, a, d);
  if (r.contains("edge_c")) {
    Vec3 corner = Crossing(line, EdgeOnA(ctx, r, "edge_c", m, job, a, d).line_mcs);
    d->fields["edge_c"]["corner_mm"] = JsonVec(corner);
    return corner;
  }
  const json& p =
      jf::Object<JobInputError>(r, "point_c", "request (plane_c, hole_c, edge_c or point_c)");
  Vec3 point = jf::Vector3<JobInputError>(p, "point_mm", "request.point_c");
  d->fields["point_c"] = {{"point_mm", JsonVec(point)}};
  return point;
}

// The 3-2-1 alignment: Z = A's normal, X along the secondary line, the origin on the line
// (on A) level with the tertiary point.
void PlaneLinePoint(JobContext& ctx,
                    const json& r,
                    const geometry::Pose3& m,
                    std::int64_t job,
                    const features::PlaneMeasurement& a,
                    Datum* d) {
  const geometry::Line3 line = SecondaryLine(ctx, r, m, job, a, d);
  const Vec3 point = TertiaryPoint(ctx, r, m, job, a, line, d);
  d->mcs_from_work = geometry::DatumPlaneLinePoint(a.plane, line, point);
}

Datum MeasureDatum(JobContext& ctx,
                   const json& r,
                   const AlignRequest& request,
                   const geometry::Pose3& flange_from_probe,
                   std::int64_t job) {
  Datum d;
  const features::PlaneMeasurement a =
      MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_a", "request"), "request.plane_a",
                  flange_from_probe, job, &d.probe);
  d.fe.points = a.points;
  d.fe.rms_mm = a.rms_mm;
  d.fields["plane_a"] = {
      {"normal", JsonVec(a.plane.normal)}, {"rms_mm", a.rms_mm}, {"points", a.points}};
  if (request.method == "plane-circle-circle")
    PlaneCircleCircle(ctx, r, flange_from_probe, job, a, &d);
  else
    PlaneLinePoint(ctx, r, flange_from_probe, job, a, &d);
  return d;
}

}  // namespace

// The pipeline: request -> evidence and datum -> record -> gate -> write -> record.
json RunAlignJob(JobContext& ctx, const json& r) {
  const MachineConfig& mc = ctx.machine;
  JobRun run(ctx, "align", r);
  json& reply = run.reply;
  try {
    const AlignRequest request = ParseAlignRequest(r);
    const calib::CalibrationRecord& cal = run.Calibration();
    Datum d = MeasureDatum(ctx, r, request, cal.flange_from_probe, run.job);
    const geometry::WorkOffsetReading wo = geometry::ReadWorkOffset(d.mcs_from_work);
    reply.update(d.fields);
    reply.update({{"method", request.method},
                  {"calibration_id", cal.calibration_id},
                  {"work_offset", request.work_offset},
                  {"origin_mm", JsonVec(wo.origin_mm)},
                  {"rotation_z_deg", wo.rotation_z_deg},
                  {"tilt_deg", wo.tilt_deg},
                  {"time_utc", base::UtcTimestamp()}});
    ctx.history.AddResult(
        run.job, {"alignment",
                  reply,
                  {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}});
    d.fe.calibration_probe = cal.probe_serial;
    d.fe.job_probe = d.probe;
    d.fe.calibration_age_h = AgeHours(cal.created_utc);
    d.fe.tilt_deg = wo.tilt_deg;
    if (request.expected_origin_mm)
      d.fe.work_shift_mm = (wo.origin_mm - *request.expected_origin_mm).norm();
    const auto problems = features::PlausibilityProblems(d.fe, mc.limits);
    if (!problems.empty()) return run.Refuse(problems);
    nc::NcResult out;
    out.header = "mlprobe job " + std::to_string(run.job) + ": " + request.method + " alignment";
    nc::WorkOffsetChange w;
    w.index = request.work_offset;
    for (int k = 0; k < 3; ++k) w.after_mm[k] = wo.origin_mm(k);
    w.rotation_after_deg = wo.rotation_z_deg;
    out.work.push_back(w);
    if (mc.controller.kind == ControllerConfig::Kind::kLinuxCnc)
      out.named = {{"status", 0.0}, {"rotation", wo.rotation_z_deg}};
    const nc::Dialect dialect = mc.controller.kind == ControllerConfig::Kind::kFanucStyle
                                    ? mc.controller.map.dialect
                                    : nc::Dialect::kLinuxCnc;
    reply["status"] = "done";  // what the job is, should a stop come before it is recorded
    reply["files"] = WriteToController(
        ctx, run.job, out, reply,
        {{"",
          nc::WorkOffsetName(dialect, request.work_offset),
          json(),
          {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}}});
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
