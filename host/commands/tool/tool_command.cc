#include "mlp/host/tool_command.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/host/cli.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/strobe.h"
#include "mlp/toolcam/tool_camera.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <set>
#include <sstream>

#include "tool_commands.h"
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::host {

namespace {

constexpr int kExitCannotPlan = 3;
constexpr const char* kUsage =
    "usage: mlp tool strobe --rpm R --fps F --resolution-deg D [--free-running]\n"
    "                       [--timer-us T] [--min-pulse-us P] [--blanking-us B]\n"
    "                       [--max-duration-s S] [--rpm-tolerance X] [--pulse-share P]\n"
    "                       [--json]\n"
    "  the strobe for shadow images of a tool turning at R rpm, a camera at F images/s, a\n"
    "  position every D degrees: pulse width, pulses per image, when they fire, the order of\n"
    "  the positions (docs/TOOLCAM.md)\n"
    "       mlp tool render --tool TOOL.json --out DIR --rpm R --fps F --resolution-deg D\n"
    "                       [--seed N] [--start-deg A] [--axis-u-px U] [--tip-v-px V]\n"
    "                       [--roll-deg A] [--pitch-deg A] [--drops N] [--spindle-y-mm Y]\n"
    "                       [--spindle-z-mm Z] [--glass-face-h-mm H] [--glass-side-y-mm F]\n"
    "                       [--view-deg V] [--drift-x-mm X] [--drift-y-mm Y] [strobe options]\n"
    "  the virtual tool camera: the plan's shadow frames (DIR/frame_NNNN.pgm), the manifest a\n"
    "  camera writes (DIR/images.json) and the truth (DIR/truth.json); the tool description\n"
    "  format: docs/TOOLCAM.md. A second camera: its view turned V deg from the first's about\n"
    "  the spindle; X, Y: the spindle off where the calibrations have it (the first camera's\n"
    "  frame: x along its view, y across), drawn but not in the manifest; H, F: the glass\n"
    "  block's face across the view at height H, or its side face along it at F (a stylus)\n"
    "       mlp tool calibrate --images DIR --pin PIN.json --out CAMERA.json [--json]\n"
    "  the camera against the machine from images of the calibration pin: scale, spindle axis,\n"
    "  gauge point, tilt about x (roll) and, with the pin's blades, about y (pitch)\n"
    "       mlp tool measure --images DIR --tool NOMINAL.json [--camera CAMERA.json]\n"
    "                        [--other-side DIR2] [--overlay FILE.png] [--json]\n"
    "                        [--save-reference TOOL.json] [--start-turn-deg A]\n"
    "                        [--second-view DIR2 --view-deg V [--second-camera CAMERA2.json]\n"
    "                         [--view-tolerance-deg T]] [--ref-height-mm H]\n"
    "  each edge's radius and length, wear and build-up from DIR/images.json (the images and\n"
    "  their angular positions; --frames is the same as --images) against the tool's\n"
    "  description (a stored reference: what changed since), with the calibration CAMERA.json\n"
    "  (else the manifest's own); a tool wholly in view is measured on both flanks; a wider\n"
    "  one on its other side too with --other-side (its -y flank's series, the spindle moved\n"
    "  across); --save-reference stores this measurement as the tool's new reference. An EDM\n"
    "  electrode: each corner's wear and the verdict against its wear limit; A is the turn\n"
    "  at the first angular position when the chuck defines it (names the corners).\n"
    "  H: the height above the tip that indexes the flutes (default: the tool file's\n"
    "  reference_height_mm, else 1.5 mm), above the end's shape.\n"
    "  With --second-view, a second camera's series of the same pulses, its view turned about\n"
    "  V deg (within T, 10) from the first's round the spindle: the spindle axis in depth and\n"
    "  each edge in space (seed 000 example 7; the tool wholly in view of both). The\n"
    "  tool table is written by the host service's tool job (mlp request, docs/HOSTD.md)\n"
    "       mlp tool render-texture --tool ELECTRODE.json --out DIR [--turns-deg 0,90,180,270]\n"
    "                       [--rotation-deg X,Y,Z] [--shift-mm X,Y,Z] [--seed N]\n"
    "                       [--texture-seed N]\n"
    "  the virtual reflected-light camera: the electrode's surface texture at the C axis'\n"
    "  turns (whole degrees), the electrode clamped turned and shifted as given\n"
    "       mlp tool relocate --reference DIR --images DIR2 --tool ELECTRODE.json\n"
    "                       [--max-tilt-deg T] [--json]\n"
    "  the electrode put back after re-clamping against its texture recorded before (seed 000\n"
    "  example 6): its six degrees of freedom; X, Y, Z, C for the machine, the tilt against\n"
    "  T (0.01 deg: over it, clamp it again)\n"
    "       mlp tool gauge-setup --masters MASTERS.csv --out SCALE.json [--json]\n"
    "  the gauge's scale and back-light edge bias from master parts' back-lit images and\n"
    "  their CMM diameters (lines: image,outer_diameter_mm,inner_diameter_mm)\n"
    "       mlp tool gauge --image PART.png --scale SCALE.json [--png OUT.png] [--json]\n"
    "  a round part (a washer's outer and inner circle) from one back-lit image: diameters\n"
    "  as a CMM's least squares, min / max, roundness, concentricity, what was left out\n"
    "exit codes: 0 done, 2 bad arguments, tool file or images, 3 cannot be planned or\n"
    "measured (the reason is printed), 1 bug\n";

struct RenderOptions {
  std::string tool, out;
  unsigned seed = 1;
  double start_deg = 17.0;  // the tool's angle at the first image: unknown to a measurement
  toolcam::ToolCameraModel camera;
  bool placed = false;  // --axis-u-px or --tip-v-px given
  toolcam::SpindleShift shift;
  // A second camera (seed 000 example 7): its view turned this far from the first's about the
  // spindle; and the spindle off where the calibrations have it, in the first camera's frame
  // (x along its view, y across its image): unknown to a measurement.
  double view_deg = 0.0, drift_x_mm = 0.0, drift_y_mm = 0.0;
};

// The render options that set the virtual camera or the spindle.
const std::set<std::string> kCameraOptions = {
    "--axis-u-px", "--tip-v-px",     "--roll-deg",     "--pitch-deg",
    "--drops",     "--spindle-y-mm", "--spindle-z-mm", "--glass-face-h-mm",
    "--view-deg",  "--drift-x-mm",   "--drift-y-mm",   "--glass-side-y-mm"};

void SetRenderCamera(const std::string& k, double v, RenderOptions* r) {
  toolcam::ToolCameraModel& c = r->camera;
  if (k == "--axis-u-px" || k == "--tip-v-px") r->placed = true;
  if (k == "--axis-u-px")
    c.axis_u_px = v;
  else if (k == "--tip-v-px")
    c.tip_v_px = v;
  else if (k == "--roll-deg")
    c.roll_deg = v;
  else if (k == "--pitch-deg")
    c.pitch_deg = v;
  else if (k == "--drops")
    c.drops_per_frame = v;
  else if (k == "--spindle-y-mm")
    r->shift.y_mm = v;
  else if (k == "--spindle-z-mm")
    r->shift.z_mm = v;
  else if (k == "--glass-face-h-mm")
    c.glass_face_h_mm = v;
  else if (k == "--glass-side-y-mm")
    c.glass_side_y_mm = v;
  else if (k == "--view-deg")
    r->view_deg = v;
  else if (k == "--drift-x-mm")
    r->drift_x_mm = v;
  else if (k == "--drift-y-mm")
    r->drift_y_mm = v;
}

ArgSpec StrobeSpec(bool rendering) {
  ArgSpec spec{{"--rpm", "--fps", "--resolution-deg", "--timer-us", "--min-pulse-us",
                "--blanking-us", "--max-duration-s", "--rpm-tolerance", "--pulse-share"},
               {"--json", "--free-running"},
               {}};
  if (rendering) {
    spec.valued.insert({"--tool", "--out", "--seed", "--start-deg"});
    spec.valued.insert(kCameraOptions.begin(), kCameraOptions.end());
  }
  return spec;
}

toolcam::StrobeRequest Parse(const std::vector<std::string>& args,
                             bool* json,
                             RenderOptions* render) {
  const Args a(args, StrobeSpec(render != nullptr));
  *json = a.Has("--json");
  toolcam::StrobeRequest r;
  r.synchronised = !a.Has("--free-running");
  r.rpm = a.Number("--rpm");
  r.frame_rate_hz = a.Number("--fps");
  r.resolution_deg = a.Number("--resolution-deg");
  r.timer_resolution_us = a.Number("--timer-us", r.timer_resolution_us);
  r.min_pulse_us = a.Number("--min-pulse-us", r.min_pulse_us);
  r.blanking_us = a.Number("--blanking-us", r.blanking_us);
  r.max_duration_s = a.Number("--max-duration-s", r.max_duration_s);
  r.rpm_tolerance = a.Number("--rpm-tolerance", r.rpm_tolerance);
  r.pulse_share = a.Number("--pulse-share", r.pulse_share);
  if (render) {
    render->tool = a.Text("--tool", "");
    render->out = a.Text("--out", "");
    render->seed = static_cast<unsigned>(a.Number("--seed", render->seed));
    render->start_deg = a.Number("--start-deg", render->start_deg);
    for (const std::string& k : kCameraOptions)
      if (a.Has(k)) SetRenderCamera(k, a.Number(k), render);
  }
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

int Render(const RenderOptions& o,
           const toolcam::StrobePlan& plan,
           std::ostream& out,
           std::ostream& err) {
  const toolcam::ToolDescription tool = toolcam::LoadTool(o.tool);
  toolcam::ToolCameraModel camera = o.camera;
  if (tool.pin && !o.placed)  // a pin whole: its axis in the middle, its end above the blades
    camera.axis_u_px = camera.width_px / 2.0 - 6.3, camera.tip_v_px = 0.52 * camera.height_px;
  camera.Validate();
  err << "mlp tool: rendering " << plan.positions << " frames of " << tool.id << "\n";
  if (!(std::abs(o.view_deg) <= 360)) throw UsageError("--view-deg must be in [-360, 360]");
  // This camera sees the tool as the first does `view_deg` of its turn later, and the drift
  // across its own image (two_views.h).
  const double view_rad = o.view_deg / base::kDegPerRad;
  const double across_mm = -std::sin(view_rad) * o.drift_x_mm + std::cos(view_rad) * o.drift_y_mm;
  const int n =
      toolcam::RenderToolSequence(tool, camera, plan, (o.start_deg - o.view_deg) / base::kDegPerRad,
                                  o.seed, o.out, o.shift, across_mm);
  out << n << " frames and truth.json in " << o.out << "\n";
  return kExitOk;
}

// `mlp tool strobe` (the plan, readable or --json) and `mlp tool render` (the plan's frames).
int StrobeOrRender(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  bool json = false;
  RenderOptions render;
  const bool rendering = args[0] == "render";
  const toolcam::StrobeRequest r =
      Parse({args.begin() + 1, args.end()}, &json, rendering ? &render : nullptr);
  if (rendering && (render.tool.empty() || render.out.empty()))
    throw UsageError("mlp tool render needs --tool and --out");
  const toolcam::StrobePlan p = toolcam::PlanStrobe(r);
  if (rendering) return Render(render, p, out, err);
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
}

}  // namespace

int RunToolCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
      out << kUsage;
      return kExitOk;
    }
    if (!args.empty() && args[0] == "measure")
      return tool::Measure({args.begin() + 1, args.end()}, out, err);
    if (!args.empty() && args[0] == "calibrate")
      return tool::Calibrate({args.begin() + 1, args.end()}, out, err);
    if (!args.empty() && args[0] == "render-texture")
      return tool::RenderTexture({args.begin() + 1, args.end()}, out, err);
    if (!args.empty() && args[0] == "relocate")
      return tool::Relocate({args.begin() + 1, args.end()}, out, err);
    if (!args.empty() && args[0] == "gauge-setup")
      return tool::GaugeSetup({args.begin() + 1, args.end()}, out, err);
    if (!args.empty() && args[0] == "gauge")
      return tool::GaugeOne({args.begin() + 1, args.end()}, out, err);
    if (args.empty() || (args[0] != "strobe" && args[0] != "render"))
      throw UsageError(
          "expected: mlp tool strobe, render, calibrate, measure, render-texture, relocate, "
          "gauge-setup or gauge ...");
    return StrobeOrRender(args, out, err);
  } catch (const UsageError& e) {
    err << "mlp tool: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  } catch (const base::InputError& e) {  // a tool, images or calibration file, a camera model
    err << "mlp tool: " << e.what() << "\n";
    return kExitBadInput;
  } catch (const toolcam::StrobeError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitCannotPlan;
  } catch (const toolcam::ToolError& e) {
    err << "mlp tool: " << e.what() << "\n";
    return kExitCannotPlan;
  }
}

}  // namespace mlp::host
