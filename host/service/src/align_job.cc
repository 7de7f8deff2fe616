#include "mlp/base/clock.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/record.h"
#include "mlp/jobs/align.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;
using geometry::Vec3;

// ---- Reading the request: every field, before any capture is loaded ------------------------

// request.NAME: {"nominal": a face, "captures": [...]}.
jobs::FaceInput ParseFace(const json& r, const char* name) {
  const std::string w = std::string("request.") + name;
  const json& f = jf::Object<JobInputError>(r, name, "request");
  jobs::FaceInput face;
  face.nominal = ParsePlaneNominal(jf::Object<JobInputError>(f, "nominal", w), w + ".nominal");
  if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
  return face;
}

// request.NAME: {"captures": [...], "nominal": a bore}.
jobs::HoleInput ParseHole(const json& r, const char* name) {
  const std::string w = std::string("request.") + name;
  const json& f = jf::Object<JobInputError>(r, name, "request");
  if (!f.contains("captures")) throw JobInputError(w + ".captures must list capture jobs");
  jobs::HoleInput hole;
  hole.nominal = ParseBoreNominal(jf::Object<JobInputError>(f, "nominal", w), w + ".nominal");
  return hole;
}

// request.NAME: {"edges": [edge captures]}.
jobs::EdgeInput ParseEdge(const json& r, const char* name) {
  const json& f = jf::Object<JobInputError>(r, name, "request");
  if (!f.contains("edges"))
    throw JobInputError(std::string("request.") + name + ".edges must list capture jobs");
  return {};
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

// The secondary line: "plane_b" (a face), or "line_b": {"edges": [...]} or {"points_mm":
// [p, q]} (machine coordinates, p -> q is X).
void ParseSecondary(const json& r, jobs::AlignInputs* in) {
  if (r.contains("plane_b")) {
    in->line_b = ParseFace(r, "plane_b");
    return;
  }
  const json& l = jf::Object<JobInputError>(r, "line_b", "request (plane_b or line_b)");
  if (l.contains("edges")) {
    in->line_b = ParseEdge(r, "line_b");
    return;
  }
  if (!l.contains("points_mm") || !l.at("points_mm").is_array() || l.at("points_mm").size() != 2)
    throw JobInputError(
        "request.line_b must hold edges (edge captures) or points_mm (two points [x, y, z])");
  in->line_b = jobs::TouchPoints{ListedPoint(l.at("points_mm")[0], "request.line_b.points_mm[0]"),
                                 ListedPoint(l.at("points_mm")[1], "request.line_b.points_mm[1]")};
}

// The tertiary point: "plane_c", "hole_c", "edge_c" or "point_c": {"point_mm"}.
void ParseTertiary(const json& r, jobs::AlignInputs* in) {
  if (r.contains("plane_c"))
    in->point_c = ParseFace(r, "plane_c");
  else if (r.contains("hole_c"))
    in->point_c = ParseHole(r, "hole_c");
  else if (r.contains("edge_c"))
    in->point_c = ParseEdge(r, "edge_c");
  else
    in->point_c = jobs::GivenPoint{jf::Vector3<JobInputError>(
        jf::Object<JobInputError>(r, "point_c", "request (plane_c, hole_c, edge_c or point_c)"),
        "point_mm", "request.point_c")};
}

jobs::AlignInputs ParseAlignRequest(const json& r) {
  jobs::AlignInputs a;
  a.method = jf::Text<JobInputError>(r, "method", "request");
  if (a.method != "plane-circle-circle" && a.method != "plane-line-point" &&
      a.method != "plane-plane-plane")
    throw JobInputError(
        "method must be plane-circle-circle, plane-line-point or plane-plane-plane");
  a.work_offset = jf::Integer<JobInputError>(r, "work_offset", "request");
  if (r.contains("expected_origin_mm"))
    a.expected_origin_mm = jf::Vector3<JobInputError>(r, "expected_origin_mm", "request");
  a.plane_a = ParseFace(r, "plane_a");
  if (a.method == "plane-circle-circle") {
    a.circle_b = ParseHole(r, "circle_b");
    a.circle_c = ParseHole(r, "circle_c");
  } else {
    ParseSecondary(r, &a);
    ParseTertiary(r, &a);
  }
  return a;
}

// ---- The evidence: each feature's captures in the machine frame ---------------------------

struct Loader {
  JobContext& ctx;
  const json& r;
  const geometry::Pose3& flange_from_probe;
  std::int64_t job;
  bool fitted_kinematics;  ///< H through the trunnion's fitted axes (a 3+2 set-up)

  Evidence Captures(const char* name) const {
    return LoadCaptures(ctx, r.at(name).at("captures"), flange_from_probe, job, fitted_kinematics);
  }
  // Every edge capture must hold an edge (taken with an "edge:x,y" ROI).
  Evidence Edges(const char* name) const {
    const json& list = r.at(name).at("edges");
    Evidence e = LoadCaptures(ctx, list, flange_from_probe, job, fitted_kinematics);
    if (e.edges.size() != list.size())
      throw JobInputError(std::string("request.") + name +
                          ".edges: a capture holds no edge (take it with an edge:x,y ROI)");
    return e;
  }
};

// In the order the features are measured: A, then B and C.
void LoadEvidence(const Loader& load, jobs::AlignInputs* in) {
  in->plane_a.evidence = load.Captures("plane_a");
  if (in->circle_b) in->circle_b->evidence = load.Captures("circle_b");
  if (in->circle_c) in->circle_c->evidence = load.Captures("circle_c");
  if (auto* b = std::get_if<jobs::FaceInput>(&in->line_b)) b->evidence = load.Captures("plane_b");
  if (auto* e = std::get_if<jobs::EdgeInput>(&in->line_b)) e->evidence = load.Edges("line_b");
  if (auto* c = std::get_if<jobs::FaceInput>(&in->point_c)) c->evidence = load.Captures("plane_c");
  if (auto* h = std::get_if<jobs::HoleInput>(&in->point_c)) h->evidence = load.Captures("hole_c");
  if (auto* e = std::get_if<jobs::EdgeInput>(&in->point_c)) e->evidence = load.Edges("edge_c");
}

}  // namespace

// The pipeline: request -> evidence -> datum and gate (mlp::jobs) -> record -> write -> record.
json RunAlignJob(JobContext& ctx, const json& r) {
  const MachineConfig& mc = ctx.machine;
  JobRun run(ctx, "align", r);
  json& reply = run.reply;
  try {
    jobs::AlignInputs in = ParseAlignRequest(r);
    const calib::CalibrationRecord& cal = run.Calibration();
    LoadEvidence({ctx, r, cal.flange_from_probe, run.job, FittedKinematics(r)}, &in);
    const jobs::AlignOutcome o = jobs::AssessAlign(
        in, {cal.calibration_id, cal.probe_serial, AgeHours(cal.created_utc)}, mc.limits);
    const geometry::WorkOffsetReading& wo = o.work;
    reply.update(ReadingsJson(o.readings));
    reply.update({{"method", in.method},
                  {"calibration_id", cal.calibration_id},
                  {"work_offset", in.work_offset},
                  {"origin_mm", JsonVec(wo.origin_mm)},
                  {"rotation_z_deg", wo.rotation_z_deg},
                  {"tilt_deg", wo.tilt_deg},
                  {"time_utc", base::UtcTimestamp()}});
    ctx.history.AddResult(
        run.job, {"alignment",
                  reply,
                  {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}});
    if (!o.refusal.empty()) return run.Refuse(o.refusal);
    const nc::NcResult out =
        jobs::AlignChanges(o, in, run.job, mc.controller.kind == ControllerConfig::Kind::kLinuxCnc);
    const nc::Dialect dialect = mc.controller.kind == ControllerConfig::Kind::kFanucStyle
                                    ? mc.controller.map.dialect
                                    : nc::Dialect::kLinuxCnc;
    reply["status"] = "done";  // what the job is, should a stop come before it is recorded
    reply["files"] = WriteToController(
        ctx, run.job, out, reply,
        {{"",
          nc::WorkOffsetName(dialect, in.work_offset),
          json(),
          {{"origin_mm", JsonVec(wo.origin_mm)}, {"rotation_z_deg", wo.rotation_z_deg}}}});
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
