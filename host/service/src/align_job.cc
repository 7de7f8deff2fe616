#include "mlp/base/clock.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/geometry/datum.h"
#include "mlp/jobs/decision.h"
#include "mlp/service/adapters.h"

#include <cmath>

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

}  // namespace

json RunAlignJob(JobContext& ctx, const json& r) {
  const MachineConfig& mc = ctx.machine;
  JobRun run(ctx, "align", r);
  json& reply = run.reply;
  const std::int64_t job = run.job;
  try {
    const calib::CalibrationRecord* cal = &run.Calibration();
    const std::string method = jf::Text<JobInputError>(r, "method", "request");
    const int index = jf::Integer<JobInputError>(r, "work_offset", "request");
    std::string probe;
    const jobs::PlaneMeasurement a =
        MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_a", "request"), "request.plane_a",
                    cal->flange_from_probe, job, &probe);
    jobs::FitEvidence fe;
    fe.points = a.points;
    fe.rms_mm = a.rms_mm;
    geometry::Pose3 mcs_from_work;
    if (method == "plane-circle-circle") {
      Vec3 centres[2];
      const char* names[2] = {"circle_b", "circle_c"};
      double min_span = 360.0;
      for (int k = 0; k < 2; ++k) {
        const std::string w = std::string("request.") + names[k];
        const json& f = jf::Object<JobInputError>(r, names[k], "request");
        if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
        const Evidence ev = LoadCaptures(ctx, f.at("captures"), cal->flange_from_probe, job);
        const jobs::BoreMeasurement b = jobs::MeasureBore(
            ev.points_mcs,
            ParseBoreNominal(jf::Object<JobInputError>(f, "nominal", w), w + ".nominal"));
        centres[k] = AxisOnPlane(b, a.plane);
        min_span = std::min(min_span, b.arc_span_deg);
        fe.rms_mm = std::max(fe.rms_mm, b.rms_mm);
        fe.points = std::min(fe.points, b.points);
        reply[names[k]] = {{"centre_mm", JsonVec(centres[k])},
                           {"diameter_mm", b.diameter_mm},
                           {"rms_mm", b.rms_mm},
                           {"points", b.points},
                           {"arc_span_deg", b.arc_span_deg}};
      }
      fe.arc_span_deg = min_span;
      mcs_from_work = geometry::DatumPlaneCircleCircle(a.plane, centres[0], centres[1]);
    } else if (method == "plane-plane-plane" || method == "plane-line-point") {
      // The 3-2-1 alignment: with a line probe the "line" is face B's trace on A and the
      // "point" is face C, each a whole face rather than 2 and 1 touch points.
      const jobs::PlaneMeasurement b =
          MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_b", "request"), "request.plane_b",
                      cal->flange_from_probe, job, &probe);
      const jobs::PlaneMeasurement c =
          MeasureFace(ctx, jf::Object<JobInputError>(r, "plane_c", "request"), "request.plane_c",
                      cal->flange_from_probe, job, &probe);
      fe.rms_mm = std::max({a.rms_mm, b.rms_mm, c.rms_mm});
      fe.points = std::min({a.points, b.points, c.points});
      // 3-2-1: A's normal is Z, the edge where B meets A sets X, C fixes the origin along it.
      geometry::Line3 edge = Intersection(a.plane, b.plane);
      const Vec3 corner = Intersection(b.plane, c.plane).point;
      mcs_from_work = geometry::DatumPlaneLinePoint(a.plane, edge, corner);
    } else {
      throw JobInputError(
          "method must be plane-circle-circle, plane-line-point or plane-plane-plane");
    }
    const geometry::WorkOffsetReading wo = geometry::ReadWorkOffset(mcs_from_work);
    reply.update(
        {{"method", method},
         {"calibration_id", cal->calibration_id},
         {"plane_a",
          {{"normal", JsonVec(a.plane.normal)}, {"rms_mm", a.rms_mm}, {"points", a.points}}},
         {"work_offset", index},
         {"origin_mm", JsonVec(wo.origin_mm)},
         {"rotation_z_deg", wo.rotation_z_deg},
         {"tilt_deg", wo.tilt_deg},
         {"time_utc", base::UtcTimestamp()}});
    ctx.history.AddResult(
        job, {"alignment",
              reply,
              {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}});
    fe.calibration_probe = cal->probe_serial;
    fe.job_probe = probe;
    fe.calibration_age_h = AgeHours(cal->created_utc);
    fe.tilt_deg = wo.tilt_deg;
    if (r.contains("expected_origin_mm"))
      fe.work_shift_mm =
          (wo.origin_mm - jf::Vector3<JobInputError>(r, "expected_origin_mm", "request")).norm();
    const auto problems = jobs::PlausibilityProblems(fe, mc.limits);
    if (!problems.empty()) {
      reply["problems"] = problems;
      reply["error"] = "nothing written: " + problems.front();
      return run.Finish(history::JobStatus::kRefused, false);
    }
    nc::NcResult out;
    out.header = "mlprobe job " + std::to_string(job) + ": " + method + " alignment";
    nc::WorkOffsetChange w;
    w.index = index;
    for (int k = 0; k < 3; ++k) w.after_mm[k] = wo.origin_mm(k);
    w.rotation_after_deg = wo.rotation_z_deg;
    out.work.push_back(w);
    if (mc.controller.kind == ControllerConfig::Kind::kLinuxCnc)
      out.named = {{"status", 0.0}, {"rotation", wo.rotation_z_deg}};
    reply["status"] = "done";  // what the job is, should a stop come before it is recorded
    reply["files"] = WriteToController(
        ctx, job, out, reply,
        {{"",
          nc::WorkOffsetName(mc.controller.kind == ControllerConfig::Kind::kFanucStyle
                                 ? mc.controller.map.dialect
                                 : nc::Dialect::kLinuxCnc,
                             index),
          json(),
          {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}}});
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
