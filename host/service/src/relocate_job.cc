// `{"op": "relocate", ...}`: an EDM electrode put back after re-clamping, found again from its
// surface texture in reflected light against the texture recorded before it was taken out
// (seed 000 example 6, toolcam/relocate.h), and its offsets written to LinuxCNC's tool table
// through the machine's one adapter: X, Y across the spindle, Z (its length) and C (its turn),
// so that G43 puts its end and its section where they were. Its tilt no four-axis machine can
// correct: over the limit, refused (clamp it again), nothing written; nor its turn on a machine
// without a C axis (the controller's `axes`), whose C offset is then not written.
//
// The chuck frame's x and y at C = 0 are the machine's X and Y (the reflected-light camera looks
// along the machine's +X at C = 0: its installation). LinuxCNC's tool offsets are the spindle
// less the tool's controlled point (its Z the length), so an electrode whose end moved by
// (dx, dy, dz) and turned by dc gets X - dx, Y - dy, Z - dz, C - dc.

#include "mlp/base/json_fields.h"
#include "mlp/nc/tool_table_update.h"
#include "mlp/service/adapters.h"
#include "mlp/toolcam/relocate.h"
#include "mlp/toolcam/tool_images_io.h"

#include <cmath>
#include <iomanip>
#include <sstream>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace jf = base::json_fields;
using json = nlohmann::json;

constexpr double kDefaultMaxTiltDeg = 0.01;  // 1.7 um over a 10 mm electrode's height

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
struct Texture {
  toolcam::ToolImageSeries images;
  std::vector<double> turn_deg;
};

Texture ReadTexture(const JobContext& ctx, const std::string& folder, const std::string& field) {
  Texture t;
  try {
    t.images = toolcam::ReadToolImageSeries(DataFolder(ctx.config.data_dir, folder, field));
  } catch (const toolcam::ToolInputError& e) {
    throw JobInputError(field + ": " + e.what());
  }
  if (!t.images.calibrated)
    throw JobInputError(field + ": images.json holds no camera calibration");
  for (int p : t.images.position) t.turn_deg.push_back(360.0 * p / t.images.positions);
  return t;
}

// The tool table's four values for tool `number`, before (the table's) and after.
nc::NcResult OffsetsResult(const MachineConfig& m,
                           std::int64_t job,
                           int number,
                           const toolcam::ToolDescription& e,
                           const toolcam::Relocation& r,
                           json* reply) {
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": electrode " + e.id + " re-located";
  const geometry::Vec3& t = r.change.translation_mm;
  json update = {{"tool", number}};
  for (const auto& [reg, change, name] :
       {std::tuple{nc::ToolRegister::kLengthGeometry, -t.z(), "length"},
        std::tuple{nc::ToolRegister::kOffsetX, -t.x(), "x"},
        std::tuple{nc::ToolRegister::kOffsetY, -t.y(), "y"},
        std::tuple{nc::ToolRegister::kOffsetC, -r.rotation_deg[2], "c"}}) {
    const char word = nc::OffsetWord(reg);
    if (word != 0 && m.controller.axes.find(word) == std::string::npos) continue;  // no such axis
    std::string note;
    out.tools.push_back(ResolveToolChange(m.controller, number, reg, change, &note));
    const std::string unit = reg == nc::ToolRegister::kOffsetC ? "_deg" : "_mm";
    update[std::string(name) + "_before" + unit] = out.tools.back().before_mm;
    update[std::string(name) + "_after" + unit] = out.tools.back().after_mm;
  }
  out.named = {{"status", 0.0}, {"tilt_deg", r.tilt_deg}};
  (*reply)["update"] = update;
  return out;
}

// What must stop the write: a control without the table's X, Y, C; the tilt over the limit;
// a change beyond the machine's limits (a wrong electrode or tool number).
std::vector<std::string> Problems(const RelocateRequest& q,
                                  const toolcam::Relocation& r,
                                  const nc::NcResult& out,
                                  const MachineConfig& m) {
  std::vector<std::string> problems;
  std::ostringstream s;
  s << std::fixed << std::setprecision(4);
  if (m.controller.kind != ControllerConfig::Kind::kLinuxCnc)
    problems.push_back(
        "a re-located electrode's X, Y and C offsets go to LinuxCNC's tool table only");
  if (r.tilt_deg > q.max_tilt_deg) {
    s << "the electrode is tilted " << r.tilt_deg << " deg, beyond " << q.max_tilt_deg
      << " deg, which no offset corrects: clamp it again";
    problems.push_back(s.str());
  }
  // Without a C axis its turn is not corrected either: the same limit.
  if (m.controller.axes.find('C') == std::string::npos &&
      std::abs(r.rotation_deg[2]) > q.max_tilt_deg) {
    std::ostringstream p;
    p << std::fixed << std::setprecision(4) << "the electrode is turned " << r.rotation_deg[2]
      << " deg and the machine has no C axis (controller.axes " << m.controller.axes << "), beyond "
      << q.max_tilt_deg << " deg: clamp it again";
    problems.push_back(p.str());
  }
  for (const nc::ToolOffsetChange& c : out.tools) {
    const bool turn = c.reg == nc::ToolRegister::kOffsetC;
    const double limit =
        turn ? nc::ToolChangeLimits{}.max_rotation_change_deg : m.limits.max_offset_change_mm;
    if (!(std::abs(c.after_mm - c.before_mm) <= limit)) {
      std::ostringstream p;
      p << std::fixed << std::setprecision(4) << "the " << nc::ToString(c.reg)
        << " would change by " << c.after_mm - c.before_mm << (turn ? " deg" : " mm") << ", beyond "
        << limit << ": a wrong electrode or tool number?";
      problems.push_back(p.str());
    }
  }
  return problems;
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

json RunRelocateJob(JobContext& ctx, const json& request) {
  JobRun run(ctx, "relocate", request);
  json& reply = run.reply;
  try {
    const RelocateRequest q = ParseRelocateRequest(request);
    const toolcam::ToolDescription e = ReadToolDescription(ctx, q.tool_file, "request.tool");
    if (!e.electrode) throw JobInputError("request.tool: " + e.id + " is not an electrode");
    const Texture ref = ReadTexture(ctx, q.reference, "request.reference");
    const Texture now = ReadTexture(ctx, q.images, "request.images");
    const toolcam::Relocation r = [&] {
      try {
        return toolcam::Relocate({ref.images.pixels, ref.turn_deg, ref.images.camera},
                                 {now.images.pixels, now.turn_deg, now.images.camera}, e);
      } catch (const toolcam::ToolInputError& x) {
        throw JobInputError(std::string("request.images: ") + x.what());
      }
    }();
    reply["tool"] = e.id;
    reply["relocation"] = RelocationJson(r);
    ctx.history.AddResult(run.job, {"relocate " + e.id,
                                    reply,
                                    {{"shift_x_mm", r.change.translation_mm.x()},
                                     {"shift_y_mm", r.change.translation_mm.y()},
                                     {"shift_z_mm", r.change.translation_mm.z()},
                                     {"turn_c_deg", r.rotation_deg[2]},
                                     {"tilt_deg", r.tilt_deg}}});
    const nc::NcResult out = OffsetsResult(ctx.machine, run.job, q.tool_number, e, r, &reply);
    const auto problems = Problems(q, r, out, ctx.machine);
    if (!problems.empty()) return run.Refuse(problems);
    return run.WriteAndFinish(out);
  } catch (const std::exception& x) {  // bad input named, or the texture not matching
    return run.Fail(x);
  }
}

}  // namespace mlp::service
