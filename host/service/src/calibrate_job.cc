#include "mlp/base/json_fields.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/calib/hand_eye_json.h"
#include "mlp/calib/recheck.h"

#include <optional>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

double Radius(const json& r) {
  const double radius = jf::Number<JobInputError>(r, "sphere_radius_mm", "request");
  if (!(radius > 0)) throw JobInputError("request.sphere_radius_mm must be > 0");
  return radius;
}

void RequireCaptures(const json& r) {
  if (!r.contains("captures")) throw JobInputError("request.captures must list capture jobs");
}

// A calibrate request, read once and checked before any capture is loaded.
calib::HandEyeOptions ParseCalibrateRequest(const json& r) {
  calib::HandEyeOptions o;
  o.sphere_radius_mm = Radius(r);
  o.max_std_mm = jf::NumberOr<JobInputError>(r, "max_std_mm", o.max_std_mm, "request");
  if (r.contains("known_centre_mm")) {
    const json& k = r.at("known_centre_mm");  // [x|null, y|null, z|null]
    if (!k.is_array() || k.size() != 3)
      throw JobInputError("request.known_centre_mm is [x, y, z] with null where unknown");
    for (size_t i = 0; i < 3; ++i)
      if (k[i].is_number()) o.known_centre_mcs[i] = k[i].get<double>();
  }
  RequireCaptures(r);
  return o;
}

// A part's feature as the recheck's artefact (seed 002's "other feature"): measured from the
// reference captures (taken before the disturbance) with the original calibration.
struct PartArtefact {
  std::string feature;  ///< "bore" or "face"; request.part.reference_captures lists the captures
  std::optional<features::BoreNominal> bore;
  std::optional<features::PlaneNominal> face;
};

PartArtefact ParsePart(const json& r) {
  const std::string w = "request.part";
  const json& p = jf::Object<JobInputError>(r, "part", "request");
  PartArtefact a;
  a.feature = jf::Text<JobInputError>(p, "feature", w);
  const json& n = jf::Object<JobInputError>(p, "nominal", w);
  if (a.feature == "bore")
    a.bore = ParseBoreNominal(n, w + ".nominal");
  else if (a.feature == "face")
    a.face = ParsePlaneNominal(n, w + ".nominal");
  else
    throw JobInputError(w + ".feature must be bore or face");
  if (!p.contains("reference_captures"))
    throw JobInputError(w + ".reference_captures must list the captures taken before");
  return a;
}

struct RecheckRequest {
  std::optional<PartArtefact> part;  ///< instead of the sphere
  double sphere_radius_mm = 0.0;
  bool sphere_moved = false;
  /// The sphere's centre measured by another probe (a touch probe after re-mounting it):
  /// the reference instead of the full calibration's centre (seed 002).
  std::optional<Eigen::Vector3d> sphere_centre_mcs;
};

RecheckRequest ParseRecheckRequest(const json& r) {
  RecheckRequest q;
  if (r.contains("part")) {
    if (r.contains("sphere_moved") || r.contains("sphere_centre_mm"))
      throw JobInputError("request: part with sphere_moved or sphere_centre_mm (one artefact)");
    q.part = ParsePart(r);
    RequireCaptures(r);
    return q;
  }
  q.sphere_radius_mm = Radius(r);
  q.sphere_moved = jf::FlagOr<JobInputError>(r, "sphere_moved", false, "request");
  if (r.contains("sphere_centre_mm"))
    q.sphere_centre_mcs = jf::Vector3<JobInputError>(r, "sphere_centre_mm", "request");
  if (q.sphere_moved && q.sphere_centre_mcs)
    throw JobInputError(
        "request: sphere_moved and sphere_centre_mm together (a centre measured by another probe "
        "is the reference, not solved again)");
  RequireCaptures(r);
  return q;
}

// The full calibration a recheck is measured against: the probe's latest, against a sphere.
calib::CalibrationRecord RecheckOriginal(const JobContext& ctx,
                                         const calib::CalibrationStore& store) {
  const auto original = store.Latest(ctx.machine.probe_serial, calib::RecordKind::kHandEye);
  if (!original)
    throw JobInputError("probe " + ctx.machine.probe_serial +
                        " has no full calibration to recheck against");
  if (original->reference != calib::Reference::kSphere)
    throw JobInputError("the latest full calibration of probe " + ctx.machine.probe_serial +
                        " was measured against a board: a recheck needs a sphere calibration");
  return *original;
}

}  // namespace

// The pipeline: request -> evidence (the stored sphere captures) -> solve -> record.
json RunCalibrateJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "calibrate", r);
  try {
    const calib::HandEyeOptions o = ParseCalibrateRequest(r);
    std::vector<calib::SphereCapture> captures;
    for (auto& s : LoadStoredCaptures(ctx, r.at("captures"), run.job))
      captures.push_back({s.id, s.mcs_from_flange, std::move(s.points_in_probe), false});
    const calib::HandEyeResult h = calib::SolveSphereHandEye(captures, o);
    const std::string id =
        calib::CalibrationStore(ctx.config.CalibrationDir())
            .Save(calib::MakeRecord(ctx.machine.probe_serial, h, captures, o.sphere_radius_mm));
    run.reply["calibration_id"] = id;
    run.reply.update(json(calib::HandEyeResultJson(h)));
    ctx.history.AddResult(run.job, {"hand-eye", run.reply, json::object()});
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const calib::HandEyeError& e) {
    run.reply["proposals"] = e.proposals();  // the poses that would determine it
    return run.Fail(e);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

// The part's reference surface: its feature measured from the reference captures with the
// original calibration's M; the reply's fields for it.
calib::PartSurface ReferenceSurface(JobContext& ctx,
                                    const PartArtefact& part,
                                    const json& reference_captures,
                                    const calib::CalibrationRecord& original,
                                    std::int64_t job,
                                    json* fields) {
  const Evidence ev = LoadCaptures(ctx, reference_captures, original.flange_from_probe, job);
  calib::PartSurface s;
  if (part.bore) {
    const features::BoreMeasurement b = features::MeasureBore(ev.points_mcs, *part.bore);
    s.kind = calib::PartSurface::Kind::kCylinder;
    s.point_mcs = b.top_centre_mcs, s.direction_mcs = b.axis_mcs, s.radius_mm = b.diameter_mm / 2;
    *fields = {{"feature", "bore"},
               {"centre_mm", JsonVec(b.top_centre_mcs)},
               {"axis", JsonVec(b.axis_mcs)},
               {"diameter_mm", b.diameter_mm},
               {"points", b.points}};
  } else {
    const features::PlaneMeasurement f = features::MeasurePlane(ev.points_mcs, *part.face);
    s.kind = calib::PartSurface::Kind::kPlane;
    s.point_mcs = f.plane.point, s.direction_mcs = f.plane.normal;
    *fields = {{"feature", "face"},
               {"point_mm", JsonVec(f.plane.point)},
               {"normal", JsonVec(f.plane.normal)},
               {"points", f.points}};
  }
  return s;
}

// The recheck itself: on the sphere, or on the part's reference surface.
calib::RecheckResult RecheckOn(JobContext& ctx,
                               const json& r,
                               const RecheckRequest& request,
                               const calib::CalibrationRecord& original,
                               const std::vector<calib::RecheckCapture>& captures,
                               JobRun* run) {
  calib::RecheckOptions o;
  o.original_flange_from_probe = original.flange_from_probe;
  if (request.part) {
    json reference;
    const calib::PartSurface surface = ReferenceSurface(
        ctx, *request.part, r.at("part").at("reference_captures"), original, run->job, &reference);
    run->reply["artefact"] = "part";
    run->reply["reference"] = reference;
    o.original_centre_mcs = original.sphere_centre_mcs;  // kept: the sphere was not measured
    return calib::RecheckOnPart(captures, surface, o);
  }
  o.sphere_radius_mm = request.sphere_radius_mm;
  o.sphere_moved = request.sphere_moved;
  o.original_centre_mcs = request.sphere_centre_mcs.value_or(original.sphere_centre_mcs);
  run->reply["artefact"] = "sphere";
  run->reply["sphere_centre_from"] =
      request.sphere_centre_mcs ? "the request (another probe)" : "the full calibration";
  return calib::Recheck(captures, o);
}

// The pipeline: request -> the original calibration -> evidence -> recheck -> record, or a
// refusal that asks for a full calibration.
json RunRecheckJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "recheck", r);
  try {
    const RecheckRequest request = ParseRecheckRequest(r);
    const calib::CalibrationStore store(ctx.config.CalibrationDir());
    const calib::CalibrationRecord original = RecheckOriginal(ctx, store);
    std::vector<calib::RecheckCapture> captures;
    for (auto& s : LoadStoredCaptures(ctx, r.at("captures"), run.job))
      captures.push_back({s.id, s.mcs_from_flange, std::move(s.points_in_probe)});
    const calib::RecheckResult c = RecheckOn(ctx, r, request, original, captures, &run);
    run.reply["parent_id"] = original.calibration_id;
    run.reply.update(json(calib::RecheckResultJson(c)));
    ctx.history.AddResult(run.job, {"recheck", run.reply, json::object()});
    if (c.full_calibration_required) {
      run.reply["error"] = "full calibration required: " + c.reason;
      return run.Finish(history::JobStatus::kRefused, false);
    }
    run.reply["calibration_id"] = store.Save(calib::MakeRecord(original, c, captures));
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
