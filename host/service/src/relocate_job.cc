// `{"op": "relocate", ...}`: an EDM electrode put back after re-clamping (mlp::jobs
// relocate.h decides), its offsets written to LinuxCNC's tool table through the machine's one
// adapter. This file reads the request and the texture folders, records and writes.

#include "mlp/base/json_fields.h"
#include "mlp/jobs/relocate.h"
#include "mlp/nc/tool_table_update.h"
#include "mlp/service/adapters.h"
#include "mlp/toolcam/relocate.h"
#include "mlp/toolcam/tool_images_io.h"

#include <cctype>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

using jobs::kDefaultMaxTiltDeg;

struct RelocateRequest {
  std::string reference, images, tool_file;
  int tool_number = 0;
  double max_tilt_deg = kDefaultMaxTiltDeg;
};

RelocateRequest ParseRelocateRequest(const json& r) {
  jf::OnlyKnownFields<JobInputError>(
      r,
      {"op", "machine", "request_id", "reference", "images", "tool", "tool_number", "max_tilt_deg"},
      "request");
  RelocateRequest q;
  q.reference = jf::Text<JobInputError>(r, "reference", "request");
  q.images = jf::Text<JobInputError>(r, "images", "request");
  q.tool_file = jf::Text<JobInputError>(r, "tool", "request");
  q.tool_number = jf::Integer<JobInputError>(r, "tool_number", "request");
  if (q.tool_number < 1) throw JobInputError("request.tool_number must be 1 or more");
  // The tilt (and, without a C axis, the turn) no offset corrects.
  q.max_tilt_deg = jf::NumberOr<JobInputError>(r, "max_tilt_deg", kDefaultMaxTiltDeg, "request");
  if (!(q.max_tilt_deg > 0 && q.max_tilt_deg <= 1))
    throw JobInputError("request.max_tilt_deg must be in (0, 1]");
  return q;
}

// A texture series named in the request: its images and the C axis' turns (positions of 360).
jobs::TextureFrames ReadTexture(const JobContext& ctx,
                                const std::string& folder,
                                const std::string& field) {
  toolcam::ToolImageSeries images;
  try {
    images = toolcam::ReadToolImageSeries(DataFolder(ctx.config.data_dir, folder, field));
  } catch (const toolcam::ToolInputError& e) {
    throw JobInputError(field + ": " + e.what());
  }
  if (!images.calibrated) throw JobInputError(field + ": images.json holds no camera calibration");
  jobs::TextureFrames t;
  for (int p : images.position) t.turn_deg.push_back(360.0 * p / images.positions);
  t.pixels = std::move(images.pixels);
  t.camera = images.camera;
  return t;
}

jobs::RelocateMachine MachineOf(const MachineConfig& m) {
  return {m.controller.axes, m.controller.kind == ControllerConfig::Kind::kLinuxCnc,
          m.limits.max_offset_change_mm, nc::ToolChangeLimits{}.max_rotation_change_deg};
}

// The changes as the controller takes them (ResolveToolChange reads LinuxCNC's table), each
// said in the reply before and after.
std::vector<nc::ToolOffsetChange> Resolved(const MachineConfig& m,
                                           int number,
                                           const std::vector<jobs::OffsetChangeAsked>& asked,
                                           json* reply) {
  std::vector<nc::ToolOffsetChange> out;
  json update = {{"tool", number}};
  for (const jobs::OffsetChangeAsked& a : asked) {
    std::string note;
    out.push_back(ResolveToolChange(m.controller, number, a.reg, a.change, &note));
    // "length_before_mm", "x_after_mm", "c_before_deg", ...
    const std::string name =
        a.reg == nc::ToolRegister::kLengthGeometry
            ? "length"
            : std::string(1, static_cast<char>(std::tolower(nc::OffsetWord(a.reg))));
    const char* unit = a.reg == nc::ToolRegister::kOffsetC ? "_deg" : "_mm";
    update[(name + "_before").append(unit)] = out.back().before_mm;
    update[(name + "_after").append(unit)] = out.back().after_mm;
  }
  (*reply)["update"] = update;
  return out;
}

json RelocationJson(const toolcam::Relocation& r) {
  const geometry::Vec3& t = r.change.translation_mm;
  return {{"rotation_deg", {r.rotation_deg[0], r.rotation_deg[1], r.rotation_deg[2]}},
          {"shift_mm", {t.x(), t.y(), t.z()}},
          {"tilt_deg", r.tilt_deg},
          {"rms_um", r.rms_um},
          {"patches", r.patches},
          {"left_out", r.left_out}};
}

}  // namespace

// The pipeline: request -> textures -> relocation (mlp::jobs) -> record -> changes and refusal
// -> write -> record.
json RunRelocateJob(JobContext& ctx, const json& request) {
  JobRun run(ctx, "relocate", request);
  json& reply = run.reply;
  try {
    const RelocateRequest q = ParseRelocateRequest(request);
    jobs::RelocateInputs in;
    in.electrode = ReadToolDescription(ctx, q.tool_file, "request.tool");
    jobs::CheckElectrode(in.electrode);
    in.tool_number = q.tool_number;
    in.max_tilt_deg = q.max_tilt_deg;
    in.reference = ReadTexture(ctx, q.reference, "request.reference");
    in.now = ReadTexture(ctx, q.images, "request.images");
    const toolcam::Relocation r = jobs::AssessRelocate(in);
    reply["tool"] = in.electrode.id;
    reply["relocation"] = RelocationJson(r);
    ctx.history.AddResult(run.job, {"relocate " + in.electrode.id,
                                    reply,
                                    {{"shift_x_mm", r.change.translation_mm.x()},
                                     {"shift_y_mm", r.change.translation_mm.y()},
                                     {"shift_z_mm", r.change.translation_mm.z()},
                                     {"turn_c_deg", r.rotation_deg[2]},
                                     {"tilt_deg", r.tilt_deg}}});
    const jobs::RelocateMachine machine = MachineOf(ctx.machine);
    const nc::NcResult out = jobs::RelocateChanges(
        in, r, run.job,
        Resolved(ctx.machine, q.tool_number, jobs::RelocateChangesAsked(r, machine), &reply));
    const auto problems = jobs::RelocateRefusal(in, r, out, machine);
    if (!problems.empty()) return run.Refuse(problems);
    return run.WriteAndFinish(out);
  } catch (const std::exception& x) {  // bad input named, or the texture not matching
    return run.Fail(x);
  }
}

}  // namespace mlp::service
