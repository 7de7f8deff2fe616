#include "mlp/jobs/tool.h"

#include "mlp/base/check.h"
#include "mlp/toolcam/touch_probe.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace mlp::jobs {
namespace {

toolcam::ToolSeries SeriesOf(const ToolFrames& f) {
  return {f.pixels, f.position, f.positions, f.camera};
}

// Seed 000 example 7: the first camera's series and a second camera's of the same pulses; the
// table gets the two cameras' largest radius and mean length (two_views.h).
ToolOutcome MeasureWithTwoCameras(const ToolInputs& in, const toolcam::MeasureOptions& options) {
  const toolcam::ToolIn3d t = [&] {
    try {
      return toolcam::MeasureToolFromTwoViews(SeriesOf(in.images), SeriesOf(*in.second_view),
                                              in.tool, in.mount, options);
    } catch (const toolcam::ToolInputError& e) {
      throw RequestError(std::string("request.second_view: ") + e.what());
    }
  }();
  ToolOutcome o;
  o.length_mm = in.tool.length_mm - t.tip_h_mm;
  o.radius_mm = *std::max_element(t.radius_mm.begin(), t.radius_mm.end());
  o.worst_finding_mm =
      std::max({t.a.worst_finding_mm, t.a.worst_wear_mm, t.b.worst_finding_mm, t.b.worst_wear_mm});
  o.over_wear_limit = t.a.OverWearLimit(in.tool) || t.b.OverWearLimit(in.tool);
  o.measurement = t;
  return o;
}

// A cutter (or a pin): its edges from the frames, on one side or both, or from two cameras.
ToolOutcome MeasureCutter(const ToolInputs& in) {
  toolcam::MeasureOptions options = toolcam::ForTool(in.tool);
  options.blur_rad = in.images.blur_rad;
  options.start_turn_deg = in.start_turn_deg;
  if (in.second_view) return MeasureWithTwoCameras(in, options);
  const ToolFrames& plus = in.images;
  const toolcam::ToolMeasurement t =
      in.other_side ? toolcam::MeasureToolBothSides(SeriesOf(plus), SeriesOf(*in.other_side),
                                                    in.tool, options)
                    : toolcam::MeasureTool(plus.pixels, plus.position, plus.positions, in.tool,
                                           plus.camera, options);
  ToolOutcome o;
  o.length_mm = in.tool.length_mm - t.tip_h_mm;
  o.radius_mm = t.radius_mm;
  o.worst_finding_mm = std::max(t.worst_finding_mm, t.worst_wear_mm);
  o.over_wear_limit = t.OverWearLimit(in.tool);
  o.measurement = t;
  return o;
}

// A touch probe's stylus: the idle ball from `images`, the glass block's face at the trigger
// from `trigger` (seed 000 Fig. 6/7): the length a probing cycle uses, the ball's radius;
// sideways the effective diameter (touch_probe.h).
ToolOutcome MeasureTouchProbe(const ToolInputs& in) {
  if (!in.trigger)
    throw RequestError("request.trigger: a stylus needs the frames taken at its trigger");
  const toolcam::ToolDescription& stylus = in.tool;
  const toolcam::TriggerCalibration t = toolcam::CalibrateTrigger(
      in.images.pixels, in.images.camera, in.trigger->pixels, in.trigger->camera, stylus);
  Readings r{{"ball_diameter_mm", t.ball_diameter_mm},
             {"ball_rms_mm", t.idle.rms_mm},
             {"pretravel_mm", t.pretravel_mm},
             {"idle_length_mm", t.idle_length_mm},
             {"trigger_length_mm", t.trigger_length_mm}};
  double diameter_mm = t.ball_diameter_mm;
  if (!in.trigger_sides.empty()) {
    std::vector<toolcam::LateralTrigger> sides;
    std::vector<Readings> seen;
    for (const ToolFrames& s : in.trigger_sides) {
      sides.push_back(toolcam::CalibrateLateralTrigger(t.idle, s.pixels, s.camera, stylus));
      seen.push_back({{"side", sides.back().side > 0 ? "+y" : "-y"},
                      {"face_y_mm", sides.back().face_y_mm},
                      {"pretravel_mm", sides.back().pretravel_mm},
                      {"effective_radius_mm", sides.back().effective_radius_mm}});
    }
    diameter_mm = toolcam::EffectiveDiameter(sides);
    r.emplace_back("lateral", std::move(seen));
    r.emplace_back("effective_diameter_mm", diameter_mm);
  }
  ToolOutcome o;
  o.length_mm = t.trigger_length_mm;
  o.radius_mm = diameter_mm / 2;
  o.measurement = std::move(r);
  return o;
}

}  // namespace

ToolOutcome AssessTool(const ToolInputs& in) {
  return in.tool.stylus ? MeasureTouchProbe(in) : MeasureCutter(in);
}

nc::NcResult ToolChanges(const ToolOutcome& o,
                         const ToolInputs& in,
                         std::int64_t job,
                         bool named_parameters,
                         const std::array<nc::ToolOffsetChange, 2>& before) {
  MLP_CHECK(before[0].reg == nc::ToolRegister::kLengthGeometry &&
            before[1].reg == nc::ToolRegister::kRadiusGeometry);
  nc::NcResult out;
  out.header = "mlprobe job " + std::to_string(job) + ": tool " + in.tool.id;
  for (size_t k = 0; k < 2; ++k) {
    nc::ToolOffsetChange c = before[k];
    if (c.incremental) c.before_mm = 0.0;  // a control without its table here: absolute
    c.incremental = false;
    c.after_mm = k == 0 ? o.length_mm : o.radius_mm;
    out.tools.push_back(c);
  }
  if (named_parameters)
    out.named = {{"status", 0.0}, {"length", o.length_mm}, {"diameter", 2 * o.radius_mm}};
  return out;
}

std::vector<std::string> ToolRefusal(const ToolOutcome& o,
                                     const ToolInputs& in,
                                     const nc::NcResult& changes,
                                     double max_offset_change_mm,
                                     bool values_known) {
  std::vector<std::string> problems;
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  if (o.over_wear_limit && !in.accept_findings) {
    s << "wear or build-up of " << o.worst_finding_mm * 1e3
      << " um beyond the tool's wear limit of " << in.tool.wear_limit_mm * 1e3
      << " um: look at the tool (accept_findings writes it anyway)";
    problems.push_back(s.str());
  }
  if (!values_known) return problems;
  for (const nc::ToolOffsetChange& c : changes.tools) {
    const bool length = c.reg == nc::ToolRegister::kLengthGeometry;
    const double change = (c.after_mm - c.before_mm) * (length ? 1 : 2);
    if (!(std::abs(change) <= max_offset_change_mm * (length ? 1 : 2))) {
      std::ostringstream p;
      p << std::fixed << std::setprecision(4) << "the " << (length ? "length" : "diameter")
        << " would change by " << change << " mm, beyond the machine's limit ("
        << max_offset_change_mm << " mm): a wrong tool or tool number?";
      problems.push_back(p.str());
    }
  }
  return problems;
}

}  // namespace mlp::jobs
