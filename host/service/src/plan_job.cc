#include "mlp/base/json_fields.h"
#include "mlp/features/plan.h"
#include "mlp/probe_fw/probe_model.h"

#include <algorithm>

#include "feature_request_json.h"
#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

features::PlanOptions ParseOptions(const json& r) {
  features::PlanOptions o;
  o.standoff_mm = jf::NumberOr<JobInputError>(r, "standoff_mm", o.standoff_mm, "request");
  o.wall_tilt_deg = jf::NumberOr<JobInputError>(r, "wall_tilt_deg", o.wall_tilt_deg, "request");
  o.patch_mm = jf::NumberOr<JobInputError>(r, "patch_mm", o.patch_mm, "request");
  o.column_step = jf::NumberOr<JobInputError>(r, "column_step", o.column_step, "request");
  o.views_per_circle = static_cast<int>(
      jf::NumberOr<JobInputError>(r, "views_per_circle", o.views_per_circle, "request"));
  o.Check();
  return o;
}

json CaptureJson(const features::PlannedCapture& c) {
  return {{"capture_id", c.id},
          {"mcs_from_flange", jf::PoseToJson(c.mcs_from_flange)},
          {"aoi", {c.aoi.x0, c.aoi.y0, c.aoi.width, c.aoi.height}},
          {"columns", {c.first_column, c.last_column, c.column_step}},
          {"roi", c.roi}};
}

// A plan request: the feature's nominal and the plan's options, read once and checked.
struct PlanRequest {
  jobs::FeatureNominal nominal;
  features::PlanOptions options;
};

PlanRequest ParsePlanRequest(const json& r, const std::string& data_dir) {
  return {ParseFeatureNominal(r, data_dir), ParseOptions(r)};
}

// The camera and projector model of the machine's probe, which a plan needs.
probe_fw::ProbeModel PlanProbeModel(const JobContext& ctx) {
  const auto probe =
      std::find_if(ctx.config.probes.begin(), ctx.config.probes.end(),
                   [&](const ProbeEntry& p) { return p.serial == ctx.machine.probe_serial; });
  if (probe == ctx.config.probes.end() || probe->model_file.empty())
    throw JobInputError("probe " + ctx.machine.probe_serial +
                        " has no model_file in the configuration: a plan needs its camera "
                        "and projector model");
  return probe_fw::LoadProbeModel(probe->model_file);
}

}  // namespace

// The pipeline: request -> the probe (its calibration and model) -> views -> captures -> reply.
json RunPlanJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "plan", r);
  try {
    const PlanRequest request = ParsePlanRequest(r, ctx.config.data_dir);
    const calib::CalibrationRecord& cal = run.Calibration();
    const probe_fw::ProbeModel model = PlanProbeModel(ctx);
    const auto plan = features::PlanCaptures(jobs::FeatureViews(request.nominal, request.options),
                                             model, cal.flange_from_probe, request.options);
    json captures = json::array();
    for (const auto& c : plan) captures.push_back(CaptureJson(c));
    run.reply["captures"] = captures;
    run.reply["calibration_id"] = cal.calibration_id;
    const std::string tilt = features::CheckReachable(plan);
    run.reply["three_axis"] = tilt.empty() ? json("reachable") : json(tilt);
    return run.Finish(history::JobStatus::kDone, true);
  } catch (const std::exception& e) {
    return run.Fail(e);
  }
}

}  // namespace mlp::service
