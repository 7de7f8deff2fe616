#include "mlp/base/json_fields.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/calib/hand_eye_json.h"
#include "mlp/calib/recheck.h"
#include "mlp/jobs/recheck.h"

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

// A part's feature as the recheck's artefact (seed 002's "other feature"): its nominal, its
// reference captures loaded later.
jobs::PartArtefact ParsePart(const json& r) {
  const std::string w = "request.part";
  const json& p = jf::Object<JobInputError>(r, "part", "request");
  jobs::PartArtefact a;
  const std::string feature = jf::Text<JobInputError>(p, "feature", w);
  const json& n = jf::Object<JobInputError>(p, "nominal", w);
  if (feature == "bore")
    a.bore = ParseBoreNominal(n, w + ".nominal");
  else if (feature == "face")
    a.face = ParsePlaneNominal(n, w + ".nominal");
  else
    throw JobInputError(w + ".feature must be bore or face");
  if (!p.contains("reference_captures"))
    throw JobInputError(w + ".reference_captures must list the captures taken before");
  return a;
}

// A recheck request, read once and checked before any capture is loaded (the captures follow).
jobs::RecheckInputs ParseRecheckRequest(const json& r) {
  jobs::RecheckInputs q;
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
    std::vector<StoredCapture> stored = LoadStoredCaptures(ctx, r.at("captures"), run.job);
    if (FittedKinematics(r)) UseFittedKinematics(ctx, &stored);
    std::vector<calib::SphereCapture> captures;
    captures.reserve(stored.size());
    for (auto& s : stored)
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

// The pipeline: request -> the original calibration -> evidence -> recheck -> record, or a
// refusal that asks for a full calibration.
json RunRecheckJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "recheck", r);
  try {
    jobs::RecheckInputs in = ParseRecheckRequest(r);
    const calib::CalibrationStore store(ctx.config.CalibrationDir());
    const calib::CalibrationRecord original = RecheckOriginal(ctx, store);
    for (auto& s : LoadStoredCaptures(ctx, r.at("captures"), run.job))
      in.captures.push_back({s.id, s.mcs_from_flange, std::move(s.points_in_probe)});
    if (in.part)
      in.part->reference = LoadCaptures(ctx, r.at("part").at("reference_captures"),
                                        original.flange_from_probe, run.job);
    const jobs::RecheckOutcome o = jobs::AssessRecheck(in, original);
    const calib::RecheckResult& c = o.result;
    run.reply["artefact"] = o.artefact;
    if (in.part)
      run.reply["reference"] = ReadingsJson(o.reference);
    else
      run.reply["sphere_centre_from"] = o.sphere_centre_from;
    run.reply["parent_id"] = original.calibration_id;
    run.reply.update(json(calib::RecheckResultJson(c)));
    ctx.history.AddResult(run.job, {"recheck", run.reply, json::object()});
    if (c.full_calibration_required) {
      run.reply["error"] = "full calibration required: " + c.reason;
      return run.Finish(history::JobStatus::kRefused, false);
    }
    run.reply["calibration_id"] = store.Save(calib::MakeRecord(original, c, in.captures));
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
