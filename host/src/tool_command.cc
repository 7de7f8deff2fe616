#include "mlp/host/tool_command.h"

#include "mlp/host/cli.h"
#include "mlp/toolcam/strobe.h"

#include <cmath>
#include <cstdlib>
#include <iomanip>

#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

constexpr int kExitCannotPlan = 3;
constexpr const char* kUsage =
    "usage: mlp tool strobe --rpm R --fps F --resolution-deg D [--free-running]\n"
    "                       [--timer-us T] [--min-pulse-us P] [--blanking-us B]\n"
    "                       [--max-duration-s S] [--rpm-tolerance X] [--json]\n"
    "  the strobe for shadow images of a tool turning at R rpm, a camera at F images/s, a\n"
    "  position every D degrees: pulse width, pulses per image, when they fire, the order of\n"
    "  the positions (docs/TOOLCAM.md)\n"
    "exit codes: 0 planned, 2 bad arguments, 3 cannot be planned (the reason is printed), 1 bug\n";

double Number(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const double x = std::strtod(v.c_str(), &end);
  if (end == v.c_str() || *end != '\0' || !std::isfinite(x))
    throw UsageError(flag + " takes a number, not \"" + v + "\"");
  return x;
}

toolcam::StrobeRequest Parse(const std::vector<std::string>& args, bool* json) {
  toolcam::StrobeRequest r;
  bool rpm = false, fps = false, res = false;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& k = args[i];
    if (k == "--json") {
      *json = true;
      continue;
    }
    if (k == "--free-running") {
      r.synchronised = false;
      continue;
    }
    if (i + 1 >= args.size()) throw UsageError(k + " needs a value");
    const double v = Number(k, args[++i]);
    if (k == "--rpm")
      r.rpm = v, rpm = true;
    else if (k == "--fps")
      r.frame_rate_hz = v, fps = true;
    else if (k == "--resolution-deg")
      r.resolution_deg = v, res = true;
    else if (k == "--timer-us")
      r.timer_resolution_us = v;
    else if (k == "--min-pulse-us")
      r.min_pulse_us = v;
    else if (k == "--blanking-us")
      r.blanking_us = v;
    else if (k == "--max-duration-s")
      r.max_duration_s = v;
    else if (k == "--rpm-tolerance")
      r.rpm_tolerance = v;
    else
      throw UsageError("unknown argument " + k);
  }
  if (!rpm || !fps || !res) throw UsageError("--rpm, --fps and --resolution-deg are required");
  return r;
}

void Print(const toolcam::StrobePlan& p, std::ostream& out) {
  out << std::fixed << std::setprecision(2) << "strobe plan: " << p.positions << " positions, "
      << p.duration_s << " s at " << p.rpm << " rpm" << (p.rpm_changed ? " (changed)" : "")
      << "\n  pulse <= " << p.step_time_us << " us (set " << p.pulse_width_us << " us), "
      << p.pulses_per_image << " per image" << std::setprecision(1);
  if (p.pulses_per_image > 1) out << ", " << p.pulse_spacing_us << " us apart";
  out << ", " << p.pulse_rate_hz << " pulses/s\n  images step " << p.skip
      << " position(s); angle error from the timer " << std::setprecision(4)
      << p.worst_angle_error_deg << " deg\n";
  if (!p.note.empty()) out << "  " << p.note << "\n";
}

}  // namespace

int RunToolCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (args.empty() || args[0] != "strobe") throw UsageError("expected: mlp tool strobe ...");
    bool json = false;
    const toolcam::StrobeRequest r = Parse({args.begin() + 1, args.end()}, &json);
    const toolcam::StrobePlan p = toolcam::PlanStrobe(r);
    if (!json) {
      Print(p, out);
      return kExitOk;
    }
    out << nlohmann::json{{"positions", p.positions},
                          {"rpm", p.rpm},
                          {"rpm_changed", p.rpm_changed},
                          {"step_time_us", p.step_time_us},
                          {"pulse_width_us", p.pulse_width_us},
                          {"pulses_per_image", p.pulses_per_image},
                          {"pulse_spacing_us", p.pulse_spacing_us},
                          {"pulse_rate_hz", p.pulse_rate_hz},
                          {"skip", p.skip},
                          {"duration_s", p.duration_s},
                          {"position", p.position},
                          {"first_pulse_us", p.first_pulse_us},
                          {"worst_angle_error_deg", p.worst_angle_error_deg},
                          {"note", p.note}}
               .dump()
        << "\n";
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp tool: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  } catch (const toolcam::StrobeError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitCannotPlan;
  }
}

}  // namespace mlp::host
