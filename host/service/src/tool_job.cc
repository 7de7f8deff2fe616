// `{"op": "tool", ...}`: a tool measured from the tool camera's images (seed 000, toolcam), or
// a touch probe's trigger from its idle and triggered frames, and its length (Z) and diameter
// (D) written to the tool table through the machine's one adapter,
// as every job's changes are: announced in the history, bounded by the machine's limit, the
// table replaced whole, logged with the values before and after. A tool worn or built up beyond
// its description's wear limit is refused with nothing written (unless accepted).

#include "mlp/base/json_fields.h"
#include "mlp/jobs/tool.h"
#include "mlp/service/adapters.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/tool_images_io.h"
#include "mlp/toolcam/touch_probe.h"
#include "mlp/toolcam/two_views.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <optional>
#include <sstream>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

constexpr std::size_t kMaxDescriptionBytes = 1u << 20;  // a tool or a camera file
// A pitch beyond this is measured through but said: realign the camera (mlp tool's figure).
constexpr double kPitchWarnDeg = 0.5;

struct ToolRequest {
  std::string images, other_side, trigger, tool_file, camera_file;
  int tool_number = 0;
  bool accept_findings = false;
  std::optional<double> start_turn_deg;  ///< the chuck's turn at position 0 (an electrode's)
  /// A stylus' frames at its lateral trigger against the block's side faces (one or two).
  std::vector<std::string> trigger_sides;
  /// A second camera's series of the same pulses (seed 000 example 7), its calibration and its
  /// view's angle from the first's (the mount's) with the tolerance.
  std::string second_view, second_camera_file;
  toolcam::SecondView mount;
};

ToolRequest ParseToolRequest(const json& r) {
  jf::OnlyKnownFields<JobInputError>(
      r,
      {"op", "machine", "request_id", "images", "other_side", "trigger", "tool", "camera",
       "tool_number", "accept_findings", "start_turn_deg", "trigger_sides", "second_view",
       "second_camera", "view_deg", "view_tolerance_deg"},
      "request");
  ToolRequest t;
  t.images = jf::Text<JobInputError>(r, "images", "request");
  if (r.contains("other_side")) t.other_side = jf::Text<JobInputError>(r, "other_side", "request");
  if (r.contains("trigger")) t.trigger = jf::Text<JobInputError>(r, "trigger", "request");
  t.tool_file = jf::Text<JobInputError>(r, "tool", "request");
  if (r.contains("camera")) t.camera_file = jf::Text<JobInputError>(r, "camera", "request");
  t.tool_number = jf::Integer<JobInputError>(r, "tool_number", "request");
  if (t.tool_number < 1) throw JobInputError("request.tool_number must be 1 or more");
  t.accept_findings = jf::FlagOr<JobInputError>(r, "accept_findings", false, "request");
  if (r.contains("start_turn_deg")) {
    const double a = jf::Number<JobInputError>(r, "start_turn_deg", "request");
    if (!(a >= -360 && a <= 360))
      throw JobInputError("request.start_turn_deg must be in [-360, 360]");
    t.start_turn_deg = a;
  }
  if (r.contains("second_view")) {
    t.second_view = jf::Text<JobInputError>(r, "second_view", "request");
    if (r.contains("second_camera"))
      t.second_camera_file = jf::Text<JobInputError>(r, "second_camera", "request");
    t.mount.view_deg = jf::Number<JobInputError>(r, "view_deg", "request");
    t.mount.tolerance_deg =
        jf::NumberOr<JobInputError>(r, "view_tolerance_deg", t.mount.tolerance_deg, "request");
  } else if (r.contains("view_deg") || r.contains("second_camera")) {
    throw JobInputError("request.view_deg and second_camera go with second_view");
  }
  if (!t.second_view.empty() && !t.other_side.empty())
    throw JobInputError("request.second_view does not go with other_side");
  if (r.contains("trigger_sides")) {
    const json& sides = r.at("trigger_sides");
    if (!sides.is_array() || sides.empty() || sides.size() > 2)
      throw JobInputError("request.trigger_sides must list one or two folders");
    for (const json& f : sides) {
      if (!f.is_string()) throw JobInputError("request.trigger_sides must list folder names");
      t.trigger_sides.push_back(f.get<std::string>());
    }
  }
  return t;
}

// One series of images a request names, read from the data folder, with its camera.
jobs::ToolFrames ReadFrames(const JobContext& ctx,
                            const std::string& folder,
                            const std::string& field,
                            const std::string& camera_json,
                            double length_mm,
                            std::vector<std::string>* warnings) {
  try {
    toolcam::ToolImageSeries images =
        toolcam::ReadToolImageSeries(DataFolder(ctx.config.data_dir, folder, field));
    jobs::ToolFrames f;
    f.camera = toolcam::ToolCameraFor(images, camera_json, "request.camera", length_mm,
                                      kPitchWarnDeg, warnings);
    f.pixels = std::move(images.pixels);
    f.position = std::move(images.position);
    f.positions = images.positions;
    f.blur_rad = images.blur_rad;
    return f;
  } catch (const toolcam::ToolInputError& e) {
    throw JobInputError(field + ": " + e.what());
  }
}

std::string CameraJson(const JobContext& ctx, const std::string& file, const std::string& field) {
  return file.empty() ? "" : ReadDataFile(ctx.config.data_dir, file, field, kMaxDescriptionBytes);
}

// The request's frames, in the order the measurement reads them: the first series, then the
// other side or the second camera's; a stylus' trigger and lateral triggers.
jobs::ToolInputs ReadInputs(const JobContext& ctx,
                            const ToolRequest& q,
                            toolcam::ToolDescription tool,
                            std::vector<std::string>* warnings) {
  const std::string camera_json = CameraJson(ctx, q.camera_file, "request.camera");
  const double length_mm = tool.length_mm;
  jobs::ToolInputs in;
  in.tool = std::move(tool);
  in.tool_number = q.tool_number;
  in.accept_findings = q.accept_findings;
  in.start_turn_deg = q.start_turn_deg;
  in.mount = q.mount;
  if (in.tool.stylus && q.trigger.empty())
    throw JobInputError("request.trigger: a stylus needs the frames taken at its trigger");
  in.images = ReadFrames(ctx, q.images, "request.images", camera_json, length_mm, warnings);
  if (in.tool.stylus) {
    in.trigger = ReadFrames(ctx, q.trigger, "request.trigger", camera_json, length_mm, warnings);
    for (const std::string& folder : q.trigger_sides)
      in.trigger_sides.push_back(
          ReadFrames(ctx, folder, "request.trigger_sides", camera_json, length_mm, warnings));
  } else if (!q.second_view.empty()) {
    in.second_view = ReadFrames(ctx, q.second_view, "request.second_view",
                                CameraJson(ctx, q.second_camera_file, "request.second_camera"),
                                length_mm, warnings);
  } else if (!q.other_side.empty()) {
    in.other_side =
        ReadFrames(ctx, q.other_side, "request.other_side", camera_json, length_mm, warnings);
  }
  return in;
}

// What was measured, in the reply: a cutter's flutes and findings (toolcam's own JSON), a
// stylus' ball, pretravel and lengths.
void SayMeasurement(const jobs::ToolInputs& in, const jobs::ToolOutcome& o, json* reply) {
  if (const auto* t = std::get_if<toolcam::ToolMeasurement>(&o.measurement)) {
    reply->update(toolcam::ToolMeasurementJson(in.tool, *t));
  } else if (const auto* t3 = std::get_if<toolcam::ToolIn3d>(&o.measurement)) {
    reply->update(toolcam::ToolIn3dJson(in.tool, *t3));
  } else {
    (*reply)["tool"] = in.tool.id;
    (*reply)["stylus"] = ReadingsJson(std::get<jobs::Readings>(o.measurement));
    (*reply)["length_mm"] = o.length_mm;
    (*reply)["diameter_mm"] = 2 * o.radius_mm;
  }
}

// The tool table's two registers as the controller holds them (ResolveToolChange reads
// LinuxCNC's table; elsewhere 0, written absolute).
std::array<nc::ToolOffsetChange, 2> RegistersBefore(const MachineConfig& m, int number) {
  std::string note;
  return {ResolveToolChange(m.controller, number, nc::ToolRegister::kLengthGeometry, 0.0, &note),
          ResolveToolChange(m.controller, number, nc::ToolRegister::kRadiusGeometry, 0.0, &note)};
}

}  // namespace

// The pipeline: request -> frames -> measure (mlp::jobs) -> record -> changes and refusal ->
// write -> record.
json RunToolJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "tool", r);
  json& reply = run.reply;
  try {
    const ToolRequest q = ParseToolRequest(r);
    std::vector<std::string> warnings;
    const jobs::ToolInputs in =
        ReadInputs(ctx, q, ReadToolDescription(ctx, q.tool_file, "request.tool"), &warnings);
    const jobs::ToolOutcome o = jobs::AssessTool(in);
    SayMeasurement(in, o, &reply);
    reply["warnings"] = warnings;
    ctx.history.AddResult(run.job, {"tool " + in.tool.id,
                                    reply,
                                    {{"diameter_mm", 2 * o.radius_mm},
                                     {"length_mm", o.length_mm},
                                     {"worst_finding_mm", o.worst_finding_mm}}});
    const bool linuxcnc = ctx.machine.controller.kind == ControllerConfig::Kind::kLinuxCnc;
    const nc::NcResult out =
        jobs::ToolChanges(o, in, run.job, linuxcnc, RegistersBefore(ctx.machine, q.tool_number));
    const auto& l = out.tools[0];
    const auto& d = out.tools[1];
    reply["update"] = {{"tool", q.tool_number},
                       {"length_before_mm", l.before_mm},
                       {"length_after_mm", l.after_mm},
                       {"diameter_before_mm", 2 * d.before_mm},
                       {"diameter_after_mm", 2 * d.after_mm}};
    const auto problems =
        jobs::ToolRefusal(o, in, out, ctx.machine.limits.max_offset_change_mm, linuxcnc);
    if (!problems.empty()) return run.Refuse(problems);
    return run.WriteAndFinish(out);
  } catch (const std::exception& e) {  // bad input named, or the images not showing the flutes
    return run.Fail(e);
  }
}

}  // namespace mlp::service
