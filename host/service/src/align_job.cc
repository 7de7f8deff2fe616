#include "mlp/base/clock.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/geometry/datum.h"
#include "mlp/jobs/decision.h"
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

// A face from the captures, segmented by its nominal (jobs::MeasurePlane).
jobs::PlaneMeasurement MeasureFace(JobContext& ctx,
                                   const json& f,
                                   const std::string& w,
                                   const geometry::Pose3& m,
                                   std::int64_t job,
                                   std::string* probe) {
  const json& n = jf::Object<JobInputError>(f, "nominal", w);
  const jobs::PlaneNominal nominal = ParsePlaneNominal(n, w + ".nominal");
  if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
  const Evidence ev = LoadCaptures(ctx, f.at("captures"), m, job);
  *probe = ev.probe_serial;
  return jobs::MeasurePlane(ev.points_mcs, nominal);
}

// Where a bore's fitted axis meets the plane.
Vec3 AxisOnPlane(const jobs::BoreMeasurement& b, const Plane& a) {
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
  jobs::FitEvidence fe;
  std::string probe;
  json fields;
};

// Plane A, then the two bores' axes where they meet it: the origin at the first, X towards
// the second.
void PlaneCircleCircle(JobContext& ctx,
                       const json& r,
                       const geometry::Pose3& m,
                       std::int64_t job,
                       const jobs::PlaneMeasurement& a,
                       Datum* d) {
  Vec3 centres[2];
  const char* names[2] = {"circle_b", "circle_c"};
  double min_span = 360.0;
  for (int k = 0; k < 2; ++k) {
    const std::string w = std::string("request.") + names[k];
    const json& f = jf::Object<JobInputError>(r, names[k], "request");
    if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
    const Evidence ev = LoadCaptures(ctx, f.at("captures"), m, job);
    const jobs::BoreMeasurement b = jobs::MeasureBore(
        ev.points_mcs,
        ParseBoreNominal(jf::Object<JobInputError>(f, "nominal", w), w + ".nominal"));
    centres[k] = AxisOnPlane(b, a.plane);
    min_span = std::min(min_span, b.arc_span_deg);
    d->fe.rms_mm = std::max(d->fe.rms_mm, b.rms_mm);
    d->fe.points = std::min(d->fe.points, b.points);
    d->fe.converged = d->fe.converged && b.converged;
    d->fields[names[k]] = {{"centre_mm", JsonVec(centres[k])},
                           {"diameter_mm", b.diameter_mm},
                           {"rms_mm", b.rms_mm},
                           {"points", b.points},
                           {"arc_span_deg", b.arc_span_deg}};
  }
  d->fe.arc_span_deg = min_span;
  d->mcs_from_work = geometry::DatumPlaneCircleCircle(a.plane, centres[0], centres[1]);
}

// The 3-2-1 alignment: with a line probe the "line" is face B's trace on A and the "point" is
// face C, each a whole face rather than 2 and 1 touch points. A's normal is Z, the edge where
// B meets A sets X, C fixes the origin along it.
void ThreePlanes(JobContext& ctx,
                 const json& r,
                 const geometry::Pose3& m,
                 std::int64_t job,
                 const jobs::PlaneMeasurement& a,
                 Datum* d) {
  const jobs::PlaneMeasurement b =
      MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_b", "request"), "request.plane_b", m,
                  job, &d->probe);
  const jobs::PlaneMeasurement c =
      MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_c", "request"), "request.plane_c", m,
                  job, &d->probe);
  d->fe.rms_mm = std::max({a.rms_mm, b.rms_mm, c.rms_mm});
  d->fe.points = std::min({a.points, b.points, c.points});
  const geometry::Line3 edge = Intersection(a.plane, b.plane);
  const Vec3 corner = Intersection(b.plane, c.plane).point;
  d->mcs_from_work = geometry::DatumPlaneLinePoint(a.plane, edge, corner);
}

Datum MeasureDatum(JobContext& ctx,
                   const json& r,
                   const AlignRequest& request,
                   const geometry::Pose3& flange_from_probe,
                   std::int64_t job) {
  Datum d;
  const jobs::PlaneMeasurement a =
      MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_a", "request"), "request.plane_a",
                  flange_from_probe, job, &d.probe);
  d.fe.points = a.points;
  d.fe.rms_mm = a.rms_mm;
  d.fields["plane_a"] = {
      {"normal", JsonVec(a.plane.normal)}, {"rms_mm", a.rms_mm}, {"points", a.points}};
  if (request.method == "plane-circle-circle")
    PlaneCircleCircle(ctx, r, flange_from_probe, job, a, &d);
  else
    ThreePlanes(ctx, r, flange_from_probe, job, a, &d);
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
    const auto problems = jobs::PlausibilityProblems(d.fe, mc.limits);
    if (!problems.empty()) {
      reply["problems"] = problems;
      reply["error"] = "nothing written: " + problems.front();
      return run.Finish(history::JobStatus::kRefused, false);
    }
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
