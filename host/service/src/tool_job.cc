// `{"op": "tool", ...}`: a tool measured from the tool camera's images (seed 000, toolcam), or
// a touch probe's trigger from its idle and triggered frames, and its length (Z) and diameter
// (D) written to the tool table through the machine's one adapter,
// as every job's changes are: announced in the history, bounded by the machine's limit, the
// table replaced whole, logged with the values before and after. A tool worn or built up beyond
// its description's wear limit is refused with nothing written (unless accepted).

#include "mlp/base/json_fields.h"
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

// One series of images a request names, read from the data folder, and its camera.
struct Series {
  toolcam::ToolImageSeries images;
  toolcam::ToolCameraModel camera;
};

Series ReadSeries(const JobContext& ctx,
                  const std::string& folder,
                  const std::string& field,
                  const std::string& camera_json,
                  double length_mm,
                  std::vector<std::string>* warnings) {
  Series s;
  try {
    s.images = toolcam::ReadToolImageSeries(DataFolder(ctx.config.data_dir, folder, field));
    s.camera = toolcam::ToolCameraFor(s.images, camera_json, "request.camera", length_mm,
                                      kPitchWarnDeg, warnings);
  } catch (const toolcam::ToolInputError& e) {
    throw JobInputError(field + ": " + e.what());
  }
  return s;
}

// What the job found for the tool table: its length and radius, and how worn it is.
struct ToolValues {
  double length_mm = 0.0, radius_mm = 0.0;
  double worst_finding_mm = 0.0;  ///< or an electrode's worst corner wear, if more
  bool over_wear_limit = false;
};

// The tool table's two values for tool `number` before (the controller's) and after (measured).
nc::NcResult ControllerResult(const MachineConfig& m,
                              std::int64_t job,
                              int number,
                              const toolcam::ToolDescription& tool,
                              const ToolValues& v,
                              json* reply) {
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": tool " + tool.id;
  for (const auto& [reg, value] : {std::pair{nc::ToolRegister::kLengthGeometry, v.length_mm},
                                   {nc::ToolRegister::kRadiusGeometry, v.radius_mm}}) {
    std::string note;
    nc::ToolOffsetChange c = ResolveToolChange(m.controller, number, reg, 0.0, &note);
    if (c.incremental) c.before_mm = 0.0;  // a control without its table here: absolute
    c.incremental = false;
    c.after_mm = value;
    out.tools.push_back(c);
  }
  if (m.controller.kind == ControllerConfig::Kind::kLinuxCnc)
    out.named = {{"status", 0.0}, {"length", v.length_mm}, {"diameter", 2 * v.radius_mm}};
  const auto& l = out.tools[0];
  const auto& r = out.tools[1];
  (*reply)["update"] = {{"tool", number},
                        {"length_before_mm", l.before_mm},
                        {"length_after_mm", l.after_mm},
                        {"diameter_before_mm", 2 * r.before_mm},
                        {"diameter_after_mm", 2 * r.after_mm}};
  return out;
}

// What must stop the write: wear beyond the tool's limit (unless accepted), a change beyond
// the machine's limit (a wrong tool or number).
std::vector<std::string> Problems(const ToolRequest& q,
                                  const toolcam::ToolDescription& tool,
                                  const ToolValues& v,
                                  const nc::NcResult& out,
                                  const MachineConfig& m) {
  std::vector<std::string> problems;
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  if (v.over_wear_limit && !q.accept_findings) {
    s << "wear or build-up of " << v.worst_finding_mm * 1e3
      << " um beyond the tool's wear limit of " << tool.wear_limit_mm * 1e3
      << " um: look at the tool (accept_findings writes it anyway)";
    problems.push_back(s.str());
  }
  for (const nc::ToolOffsetChange& c : out.tools) {
    const bool length = c.reg == nc::ToolRegister::kLengthGeometry;
    const double change = (c.after_mm - c.before_mm) * (length ? 1 : 2);
    if (m.controller.kind == ControllerConfig::Kind::kLinuxCnc &&
        !(std::abs(change) <= m.limits.max_offset_change_mm * (length ? 1 : 2))) {
      std::ostringstream p;
      p << std::fixed << std::setprecision(4) << "the " << (length ? "length" : "diameter")
        << " would change by " << change << " mm, beyond the machine's limit ("
        << m.limits.max_offset_change_mm << " mm): a wrong tool or tool number?";
      problems.push_back(p.str());
    }
  }
  return problems;
}

// Seed 000 example 7: the first camera's series and a second camera's of the same pulses; the
// table gets the two cameras' mean radius and length (two_views.h).
ToolValues MeasureWithTwoCameras(const JobContext& ctx,
                                 const ToolRequest& q,
                                 const toolcam::ToolDescription& tool,
                                 const Series& a,
                                 const toolcam::MeasureOptions& options,
                                 std::vector<std::string>* warnings,
                                 json* reply) {
  if (!q.other_side.empty()) throw JobInputError("request.second_view does not go with other_side");
  const std::string camera_json = q.second_camera_file.empty()
                                      ? ""
                                      : ReadDataFile(ctx.config.data_dir, q.second_camera_file,
                                                     "request.second_camera", kMaxDescriptionBytes);
  const Series b =
      ReadSeries(ctx, q.second_view, "request.second_view", camera_json, tool.length_mm, warnings);
  const toolcam::ToolIn3d t = [&] {
    try {
      return toolcam::MeasureToolFromTwoViews(
          {a.images.pixels, a.images.position, a.images.positions, a.camera},
          {b.images.pixels, b.images.position, b.images.positions, b.camera}, tool, q.mount,
          options);
    } catch (const toolcam::ToolInputError& e) {
      throw JobInputError(std::string("request.second_view: ") + e.what());
    }
  }();
  reply->update(toolcam::ToolIn3dJson(tool, t));
  const double radius = *std::max_element(t.radius_mm.begin(), t.radius_mm.end());
  const double worst =
      std::max({t.a.worst_finding_mm, t.a.worst_wear_mm, t.b.worst_finding_mm, t.b.worst_wear_mm});
  return {tool.length_mm - t.tip_h_mm, radius, worst,
          t.a.OverWearLimit(tool) || t.b.OverWearLimit(tool)};
}

// A cutter (or a pin): its edges from the images, on one side or both.
ToolValues MeasureCutter(const JobContext& ctx,
                         const ToolRequest& q,
                         const toolcam::ToolDescription& tool,
                         const std::string& camera_json,
                         std::vector<std::string>* warnings,
                         json* reply) {
  const Series plus =
      ReadSeries(ctx, q.images, "request.images", camera_json, tool.length_mm, warnings);
  toolcam::MeasureOptions options = toolcam::ForTool(tool);
  options.blur_rad = plus.images.blur_rad;
  options.start_turn_deg = q.start_turn_deg;
  if (!q.second_view.empty())
    return MeasureWithTwoCameras(ctx, q, tool, plus, options, warnings, reply);
  toolcam::ToolMeasurement t;
  if (q.other_side.empty()) {
    t = toolcam::MeasureTool(plus.images.pixels, plus.images.position, plus.images.positions, tool,
                             plus.camera, options);
  } else {
    const Series minus =
        ReadSeries(ctx, q.other_side, "request.other_side", camera_json, tool.length_mm, warnings);
    t = toolcam::MeasureToolBothSides(
        {plus.images.pixels, plus.images.position, plus.images.positions, plus.camera},
        {minus.images.pixels, minus.images.position, minus.images.positions, minus.camera}, tool,
        options);
  }
  reply->update(toolcam::ToolMeasurementJson(tool, t));
  return {tool.length_mm - t.tip_h_mm, t.radius_mm, std::max(t.worst_finding_mm, t.worst_wear_mm),
          t.OverWearLimit(tool)};
}

// A touch probe's stylus: the idle ball from `images`, the glass block's face at the trigger
// from `trigger` (seed 000 Fig. 6/7): the length a probing cycle uses, the ball's radius.
ToolValues MeasureTouchProbe(const JobContext& ctx,
                             const ToolRequest& q,
                             const toolcam::ToolDescription& stylus,
                             const std::string& camera_json,
                             std::vector<std::string>* warnings,
                             json* reply) {
  if (q.trigger.empty())
    throw JobInputError("request.trigger: a stylus needs the frames taken at its trigger");
  const Series idle =
      ReadSeries(ctx, q.images, "request.images", camera_json, stylus.length_mm, warnings);
  const Series trigger =
      ReadSeries(ctx, q.trigger, "request.trigger", camera_json, stylus.length_mm, warnings);
  const toolcam::TriggerCalibration t = toolcam::CalibrateTrigger(
      idle.images.pixels, idle.camera, trigger.images.pixels, trigger.camera, stylus);
  (*reply)["tool"] = stylus.id;
  (*reply)["stylus"] = {{"ball_diameter_mm", t.ball_diameter_mm},
                        {"ball_rms_mm", t.idle.rms_mm},
                        {"pretravel_mm", t.pretravel_mm},
                        {"idle_length_mm", t.idle_length_mm},
                        {"trigger_length_mm", t.trigger_length_mm}};
  // Sideways: the diameter a probing cycle uses is the effective one (touch_probe.h).
  double diameter_mm = t.ball_diameter_mm;
  if (!q.trigger_sides.empty()) {
    std::vector<toolcam::LateralTrigger> sides;
    json seen = json::array();
    for (const std::string& folder : q.trigger_sides) {
      const Series s =
          ReadSeries(ctx, folder, "request.trigger_sides", camera_json, stylus.length_mm, warnings);
      sides.push_back(toolcam::CalibrateLateralTrigger(t.idle, s.images.pixels, s.camera, stylus));
      seen.push_back({{"side", sides.back().side > 0 ? "+y" : "-y"},
                      {"face_y_mm", sides.back().face_y_mm},
                      {"pretravel_mm", sides.back().pretravel_mm},
                      {"effective_radius_mm", sides.back().effective_radius_mm}});
    }
    diameter_mm = toolcam::EffectiveDiameter(sides);
    (*reply)["stylus"]["lateral"] = seen;
    (*reply)["stylus"]["effective_diameter_mm"] = diameter_mm;
  }
  (*reply)["length_mm"] = t.trigger_length_mm;
  (*reply)["diameter_mm"] = diameter_mm;
  return {t.trigger_length_mm, diameter_mm / 2, 0.0, false};
}

}  // namespace

json RunToolJob(JobContext& ctx, const json& r) {
  JobRun run(ctx, "tool", r);
  json& reply = run.reply;
  try {
    const ToolRequest q = ParseToolRequest(r);
    const toolcam::ToolDescription tool = ReadToolDescription(ctx, q.tool_file, "request.tool");
    const std::string camera_json = q.camera_file.empty()
                                        ? ""
                                        : ReadDataFile(ctx.config.data_dir, q.camera_file,
                                                       "request.camera", kMaxDescriptionBytes);
    std::vector<std::string> warnings;
    const ToolValues v = tool.stylus
                             ? MeasureTouchProbe(ctx, q, tool, camera_json, &warnings, &reply)
                             : MeasureCutter(ctx, q, tool, camera_json, &warnings, &reply);
    reply["warnings"] = warnings;
    ctx.history.AddResult(run.job, {"tool " + tool.id,
                                    reply,
                                    {{"diameter_mm", 2 * v.radius_mm},
                                     {"length_mm", v.length_mm},
                                     {"worst_finding_mm", v.worst_finding_mm}}});
    const nc::NcResult out = ControllerResult(ctx.machine, run.job, q.tool_number, tool, v, &reply);
    const auto problems = Problems(q, tool, v, out, ctx.machine);
    if (!problems.empty()) return run.Refuse(problems);
    return run.WriteAndFinish(out);
  } catch (const std::exception& e) {  // bad input named, or the images not showing the flutes
    return run.Fail(e);
  }
}

}  // namespace mlp::service
