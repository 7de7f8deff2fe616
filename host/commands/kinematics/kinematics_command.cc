#include "mlp/host/kinematics_command.h"

#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/trunnion_hal.h"
#include "mlp/calib/trunnion_report.h"
#include "mlp/host/cli.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <map>
#include <optional>
#include <ostream>
#include <sstream>

#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <spawn.h>
#include <sys/wait.h>

namespace mlp::host {
namespace {

using json = nlohmann::json;
using geometry::Pose3;
using geometry::Vec3;

constexpr const char* kUsage =
    "usage: mlp kinematics check --centres FILE (--pins HALFILE | --pin NAME=MM ...)\n"
    "                            [--limit-um U]\n"
    "                            [--square-limit-deg D] [--svg FILE] [--json]\n"
    "  A trunnion (A tilting about X carrying C; LinuxCNC's xyzac-trt-kins) checked from sphere\n"
    "  centres measured at A and C positions (FILE: mlprobe-trunnion-centres/1), against the\n"
    "  pins the machine starts with (HALFILE: its setp xyzac-trt-kins.* lines).\n"
    "  --limit-um: largest pivot error accepted (default 10); --square-limit-deg: largest\n"
    "  squareness (default 0.01). Exit 0 within, 3 beyond a limit, 4 the centres cannot\n"
    "  determine the axes, 2 bad input.\n"
    "usage: mlp kinematics calibrate --centres FILE --pins HALFILE [--null-band-um U]\n"
    "                                [--max-change-um U] [--write] [--log FILE] [--json]\n"
    "  The pins that put the kinematics on the axes the centres give (FILE as for check, or a\n"
    "  kinematics job's reply): a pin changes only beyond the null band (default 2 um) and 3\n"
    "  of its uncertainties; a change beyond --max-change-um (default 200) refuses them all.\n"
    "  Without --write it says what it would write. With --write, HALFILE's four values are\n"
    "  rewritten whole (every other byte kept) and before/after appended to --log (default\n"
    "  HALFILE.log); refused while LinuxCNC runs (halcmd answers): a running machine's pins\n"
    "  are set by the kinematics job through M101, at rest (docs/KINEMATICS.md). Exit 0\n"
    "  nothing to change or written, 3 changes not written, 4 undetermined, 6 refused.\n"
    "usage: mlp kinematics plan --pins HALFILE --sphere X,Y,Z [--a A1,A2,...] [--c N]\n"
    "                           [--spindle DEG] [--probe-length MM] [--standoff MM]\n"
    "                           [--table-radius MM] [--table-top MM] [--margin MM]\n"
    "                           [--out PROGRAM.ngc] [--capture-jobs FIRST] [--json]\n"
    "  The stops of a sphere check (the sphere at X,Y,Z in the table's frame; A at each of\n"
    "  --a, default -30,0,30,60,90; C at N positions a turn, default 4) and an NC program that\n"
    "  moves to them in machine coordinates: retract to a clearance height above every stop\n"
    "  and the table's rim, turn there, move over, go down; with --capture-jobs, the spindle\n"
    "  oriented to --spindle first and M101 P<FIRST + i> at stop i (i from 0): the capture\n"
    "  jobs' files, each with \"pose_frame\": \"machine\", are the machine's "
    "(docs/KINEMATICS.md).\n"
    "usage: mlp kinematics flange-pose (--pins HALFILE | --pin NAME=MM ...) --joints X,Y,Z,A,C\n"
    "                                  [--spindle DEG]\n"
    "  H, the spindle flange in the table's frame, from the joints and the pins (a capture's\n"
    "  mcs_from_flange: translation_mm and rotation_vector_rad, JSON); --pin takes the running\n"
    "  machine's values (halcmd getp xyzac-trt-kins.NAME), x-rot-point to z-offset, tool-offset.\n";

// The pins from a HAL file or from NAME=MM values (the running machine's, as M101 reads them),
// one source or the other.
calib::TrtPins PinsOf(const Args& a) {
  if (a.Has("--pins") == !a.All("--pin").empty())
    throw UsageError("give the pins once: --pins HALFILE or --pin NAME=MM for each");
  if (a.Has("--pins")) return ParseTrtPinsHal(ReadInputFile(a.Text("--pins")));
  std::string hal;
  for (const std::string& v : a.All("--pin")) {
    const size_t eq = v.find('=');
    if (eq == std::string::npos || eq == 0)
      throw UsageError("--pin takes NAME=MM, not '" + v + "'");
    hal += "setp xyzac-trt-kins." + v.substr(0, eq) + " " + v.substr(eq + 1) + "\n";
  }
  return ParseTrtPinsHal(hal);
}

struct Command {
  std::string centres, svg;
  calib::TrtPins pins;
  double limit_mm = 0.010, square_limit_deg = 0.01;
  bool json = false;
};

Command Parse(const std::vector<std::string>& args) {
  if (args.empty() || args[0] != "check")
    throw UsageError("the commands are check, calibrate, plan and flange-pose");
  const Args a({args.begin() + 1, args.end()},
               ArgSpec({"--centres", "--pins", "--limit-um", "--square-limit-deg", "--svg"},
                       {"--json"}, {"--pin"}));
  Command c;
  c.centres = a.Text("--centres");
  c.pins = PinsOf(a);
  c.svg = a.Text("--svg", "");
  c.limit_mm = a.Number("--limit-um", 10.0) * 1e-3;
  c.square_limit_deg = a.Number("--square-limit-deg", 0.01);
  c.json = a.Has("--json");
  if (!(c.limit_mm > 0) || !(c.square_limit_deg > 0))
    throw UsageError("--limit-um and --square-limit-deg must be > 0");
  return c;
}

// The axes from the centres, or why they cannot be found said on `err`.
std::optional<calib::TrunnionFit> FitOrSay(const std::vector<calib::TrunnionObservation>& centres,
                                           const calib::TrtPins& pins,
                                           std::ostream& err) {
  try {
    return calib::FitTrunnion(centres, calib::AxesOf(pins));
  } catch (const calib::TrunnionError& e) {
    err << "mlp kinematics: " << e.what() << "\n";
    return std::nullopt;
  }
}

int Check(const Command& c, std::ostream& out, std::ostream& err) {
  const calib::TrtPins& pins = c.pins;
  const std::vector<calib::TrunnionObservation> centres =
      ParseTrunnionCentres(ReadInputFile(c.centres));
  const std::optional<calib::TrunnionFit> fitted = FitOrSay(centres, pins, err);
  if (!fitted) return kExitUndetermined;
  const calib::TrunnionFit& fit = *fitted;
  const calib::TrunnionLimits limits{c.limit_mm, c.square_limit_deg};
  const bool within = calib::TrunnionWithin(fit, pins, limits);
  if (!c.svg.empty()) WriteOutputFile(c.svg, calib::TrunnionSvg(centres, fit, pins, c.limit_mm));
  if (c.json) {
    out << calib::TrunnionReportJson(centres, fit, pins, limits).dump(2) << "\n";
  } else {
    out << calib::TrunnionReportText(centres, fit, pins, limits)
        << (within ? " within the limits\n"
                   : " BEYOND a limit: mlp kinematics calibrate (the pins), or the machine's "
                     "service (what no pin holds)\n");
  }
  return within ? static_cast<int>(kExitOk) : static_cast<int>(kExitKinematicsOff);
}

struct CalibrateCommand {
  std::string centres, hal, log;
  double null_band_mm = 0.002, max_change_mm = 0.2;
  bool write = false, json = false;
};

CalibrateCommand ParseCalibrate(const std::vector<std::string>& args) {
  const Args a({args.begin() + 1, args.end()},
               ArgSpec({"--centres", "--pins", "--null-band-um", "--max-change-um", "--log"},
                       {"--write", "--json"}));
  CalibrateCommand c;
  c.centres = a.Text("--centres");
  c.hal = a.Text("--pins");
  c.log = a.Text("--log", c.hal + ".log");
  c.null_band_mm = a.Number("--null-band-um", 2.0) * 1e-3;
  c.max_change_mm = a.Number("--max-change-um", 200.0) * 1e-3;
  c.write = a.Has("--write");
  c.json = a.Has("--json");
  if (!(c.null_band_mm >= 0) || !(c.max_change_mm > 0))
    throw UsageError("--null-band-um must be >= 0 and --max-change-um > 0");
  return c;
}

// True when a LinuxCNC with the trunnion's kinematics is running here (halcmd reads its pin).
// Its live pins are then what the machine moves by; a file rewritten under it would disagree
// with them until the next start, so the command leaves a running machine to the job (M101).
bool TrunnionControllerRuns() {
  const std::array<const char*, 5> argv = {"halcmd", "-s", "getp", "xyzac-trt-kins.x-rot-point",
                                           nullptr};
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  // posix_spawnp takes argv as char* const*: halcmd does not write to them.
  const int spawned =
      posix_spawnp(&pid, argv[0], &quiet, nullptr, const_cast<char* const*>(argv.data()), environ);
  posix_spawn_file_actions_destroy(&quiet);
  if (spawned != 0) return false;  // no halcmd: no LinuxCNC here
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

std::string ChangesText(const calib::PinCalibration& c) {
  std::string t;
  for (const calib::PinChange& p : c.changes)
    t += "  " + p.name + ": " + Fixed(p.before_mm, 4) + " -> " + Fixed(p.after_mm, 4) +
         (p.changed ? " (" + Fixed((p.after_mm - p.before_mm) * 1e3, 1) + " um, +-" +
                          Fixed(p.u_mm * 1e3, 1) + " um)\n"
                    : " (kept: within the null band or 3 u)\n");
  return t;
}

// The file rewritten whole under a lock (two calibrations never interleave their read and
// write), the intent logged before and the result after: a log that ends in an intent says a
// write may not have happened.
void WritePins(const CalibrateCommand& c,
               const calib::TrtPins& read,
               const calib::PinCalibration& p) {
  const base::FileLock lock(c.hal + ".lock");
  const std::string text = ReadInputFile(c.hal);
  const calib::TrtPins now = ParseTrtPinsHal(text);
  if (now.x_rot_point != read.x_rot_point || now.y_rot_point != read.y_rot_point ||
      now.z_rot_point != read.z_rot_point || now.y_offset != read.y_offset ||
      now.z_offset != read.z_offset || now.tool_offset != read.tool_offset)
    throw base::FileError(c.hal + " changed while the calibration was computed: nothing written");
  json record = {{"time_utc", base::UtcNow("%Y-%m-%dT%H:%M:%SZ", false)},
                 {"file", c.hal},
                 {"centres", c.centres},
                 {"changes", calib::PinChangesJson(p.changes)}};
  record["state"] = "intent";
  base::AppendRecord(c.log, "", record.dump() + "\n");
  base::WriteFileAtomically(c.hal, calib::RewriteTrtPinsHal(text, p.pins));
  record["state"] = "written";
  base::AppendRecord(c.log, "", record.dump() + "\n");
}

int Calibrate(const CalibrateCommand& c, std::ostream& out, std::ostream& err) {
  const calib::TrtPins pins = ParseTrtPinsHal(ReadInputFile(c.hal));
  const std::optional<calib::TrunnionFit> fitted =
      FitOrSay(ParseTrunnionCentres(ReadInputFile(c.centres)), pins, err);
  if (!fitted) return kExitUndetermined;
  const calib::TrunnionFit& fit = *fitted;
  const calib::PinCalibration p = calib::CalibratePins(fit, pins, c.null_band_mm, c.max_change_mm);
  const bool any = std::any_of(p.changes.begin(), p.changes.end(),
                               [](const calib::PinChange& x) { return x.changed; });
  std::string refused;
  if (!p.problems.empty())
    refused = p.problems.front();
  else if (c.write && any && TrunnionControllerRuns())
    refused =
        "LinuxCNC is running with xyzac-trt-kins (halcmd reads its pins): nothing written; "
        "a running machine's pins are set by the kinematics job through M101 at rest "
        "(docs/KINEMATICS.md), or stop the machine first";
  bool written = c.write && any && refused.empty();
  if (written) {
    try {
      WritePins(c, pins, p);
    } catch (const base::FileError& e) {
      written = false;
      refused = e.what();
    }
  }
  if (c.json) {
    out << json{{"file", c.hal},
                {"changes", calib::PinChangesJson(p.changes)},
                {"residual_rms_mm", fit.residual_rms_mm},
                {"written", written},
                {"refused", refused.empty() ? json() : json(refused)}}
               .dump(2)
        << "\n";
  } else {
    out << calib::Describe(fit, pins) << "calibration of " << c.hal << ":\n" << ChangesText(p);
    if (!any)
      out << "nothing to change: the pins fit the axes\n";
    else if (written)
      out << "written; before/after in " << c.log << "; the machine reads it at its next start\n";
    else if (refused.empty())
      out << "not written (dry run): --write to write\n";
  }
  if (!refused.empty()) {
    err << "mlp kinematics: refused: " << refused << "\n";
    return kExitCalibrationRefused;
  }
  return (any && !written) ? static_cast<int>(kExitKinematicsOff) : static_cast<int>(kExitOk);
}

std::string Coordinate(double v) { return Fixed(std::abs(v) < 5e-7 ? 0.0 : v, 6); }

// The program of a plan for LinuxCNC's xyzac-trt-kins with its type on motion.analog-out-03
// (samples/linuxcnc/mlprobe-5axis/trt_sim.hal): identity kinematics for the moves (X Y Z A C
// are the joints: the retract is straight up whatever the table's tilt), each stop said on the
// operator's channel, the trunnion's kinematics back at the end.
std::string PlanProgram(const calib::TrunnionPlan& plan,
                        const Vec3& sphere,
                        double spindle_deg,
                        std::int64_t first_job) {
  std::ostringstream p;
  const std::string clear = "G53 G0 Z" + Coordinate(plan.clear_gauge_z_mm) + "\n";
  p << "(mlprobe trunnion check: " << plan.stops.size() << " stops, the sphere at "
    << Coordinate(sphere.x()) << " " << Coordinate(sphere.y()) << " " << Coordinate(sphere.z())
    << " on the table; written by mlp kinematics plan)\n"
    << "G21 G90 G40\nM68 E3 Q1 (identity kinematics: X Y Z A C are the joints)\nM66 E0 L0\n"
    << clear;
  if (first_job > 0) p << "M19 R" << Coordinate(spindle_deg) << " (the probe's turn, held)\n";
  for (size_t i = 0; i < plan.stops.size(); ++i) {
    const calib::TrunnionStop& s = plan.stops[i];
    p << "(stop " << i + 1 << " of " << plan.stops.size() << ")\n"
      << "G53 G0 A" << Coordinate(s.a_deg) << " C" << Coordinate(s.c_deg) << "\n"
      << "G53 G0 X" << Coordinate(s.gauge_machine_mm.x()) << " Y"
      << Coordinate(s.gauge_machine_mm.y()) << "\n"
      << "G53 G0 Z" << Coordinate(s.gauge_machine_mm.z()) << "\n"
      << "(DEBUG, mlp stop " << i + 1 << " #5420 #5421 #5422 #5423 #5425)\n";
    if (first_job > 0)
      p << "M101 P" << first_job + static_cast<std::int64_t>(i) << " (capture at stop " << i + 1
        << ")\n";
    p << clear;
  }
  p << "M68 E3 Q0 (the trunnion's kinematics again)\nM66 E0 L0\nM2\n";
  return p.str();
}

int Plan(const std::vector<std::string>& args, std::ostream& out) {
  const Args a(
      {args.begin() + 1, args.end()},
      ArgSpec({"--pins", "--sphere", "--a", "--c", "--spindle", "--probe-length", "--standoff",
               "--table-radius", "--table-top", "--margin", "--out", "--capture-jobs"},
              {"--json"}));
  const calib::TrtPins pins = ParseTrtPinsHal(ReadInputFile(a.Text("--pins")));
  const std::vector<double> xyz = base::ParseNumberList("--sphere", a.Text("--sphere"));
  if (xyz.size() != 3) throw UsageError("--sphere takes X,Y,Z");
  calib::TrunnionPlanOptions o;
  if (a.Has("--a")) o.a_deg = base::ParseNumberList("--a", a.Text("--a"));
  o.c_count = static_cast<int>(a.Integer("--c", 4, 3));
  o.spindle_deg = a.Number("--spindle", 0.0);
  o.probe_length_mm = a.Number("--probe-length", o.probe_length_mm);
  o.standoff_mm = a.Number("--standoff", o.standoff_mm);
  o.table_radius_mm = a.Number("--table-radius", 0.0);
  o.table_top_mm = a.Number("--table-top", 0.0);
  o.margin_mm = a.Number("--margin", o.margin_mm);
  const Vec3 sphere(xyz[0], xyz[1], xyz[2]);
  calib::TrunnionPlan plan;
  try {
    plan = calib::PlanTrunnionCheck(calib::AxesOf(pins), sphere, o);
  } catch (const calib::TrunnionError& e) {
    throw UsageError(e.what());
  }
  const std::int64_t first_job = a.Integer("--capture-jobs", 0, 1);
  if (a.Has("--out"))
    WriteOutputFile(a.Text("--out"), PlanProgram(plan, sphere, o.spindle_deg, first_job));
  if (a.Has("--json")) {
    json stops = json::array();
    for (const auto& s : plan.stops) {
      stops.push_back({{"a_deg", s.a_deg},
                       {"c_deg", s.c_deg},
                       {"gauge_machine_mm",
                        {s.gauge_machine_mm.x(), s.gauge_machine_mm.y(), s.gauge_machine_mm.z()}}});
    }
    out << json{{"clear_gauge_z_mm", plan.clear_gauge_z_mm}, {"stops", stops}}.dump(2) << "\n";
    return kExitOk;
  }
  out << plan.stops.size() << " stops, turns made with the gauge point at Z "
      << Fixed(plan.clear_gauge_z_mm, 3) << " (machine):\n";
  for (const auto& s : plan.stops) {
    out << "  A " << Fixed(s.a_deg, 3) << " C " << Fixed(s.c_deg, 3) << ": X "
        << Fixed(s.gauge_machine_mm.x(), 3) << " Y " << Fixed(s.gauge_machine_mm.y(), 3) << " Z "
        << Fixed(s.gauge_machine_mm.z(), 3) << "\n";
  }
  return kExitOk;
}

int FlangePose(const std::vector<std::string>& args, std::ostream& out) {
  const Args a({args.begin() + 1, args.end()},
               ArgSpec({"--pins", "--joints", "--spindle"}, {}, {"--pin"}));
  const calib::TrtPins pins = PinsOf(a);
  const std::vector<double> j = base::ParseNumberList("--joints", a.Text("--joints"));
  if (j.size() != 5) throw UsageError("--joints takes X,Y,Z,A,C");
  const Pose3 h = calib::TableFromFlange(calib::AxesOf(pins), Vec3(j[0], j[1], j[2]), j[3], j[4],
                                         a.Number("--spindle", 0.0));
  out << base::json_fields::PoseToJson(h).dump() << "\n";
  return kExitOk;
}

}  // namespace

calib::TrtPins ParseTrtPinsHal(const std::string& text) {
  try {
    return calib::ParseTrtPinsHal(text);
  } catch (const calib::TrunnionError& e) {
    throw UsageError(e.what());
  }
}

std::vector<calib::TrunnionObservation> ParseTrunnionCentres(const std::string& text) {
  const json j = json::parse(text, nullptr, false);
  // A kinematics job's reply carries the same centres as "spheres" (docs/HOSTD.md).
  const bool reply = j.is_object() && !j.contains("format") && j.contains("spheres");
  const char* key = reply ? "spheres" : "centres";
  if (j.is_discarded() || !j.is_object() ||
      (!reply && j.value("format", "") != "mlprobe-trunnion-centres/1") || !j.contains(key) ||
      !j[key].is_array())
    throw UsageError("centres: not a mlprobe-trunnion-centres/1 file or a kinematics job's reply");
  std::vector<calib::TrunnionObservation> out;
  for (const json& c : j[key]) {
    const json& m = c.value("centre_mm", json());
    if (!c.is_object() || !c.contains("a_deg") || !c["a_deg"].is_number() || !c.contains("c_deg") ||
        !c["c_deg"].is_number() || !m.is_array() || m.size() != 3 ||
        !std::all_of(m.begin(), m.end(), [](const json& v) { return v.is_number(); }))
      throw UsageError("centres: each needs a_deg, c_deg and centre_mm [x, y, z]");
    calib::TrunnionObservation o{c["a_deg"].get<double>(), c["c_deg"].get<double>(),
                                 Vec3(m[0].get<double>(), m[1].get<double>(), m[2].get<double>())};
    if (!o.centre_machine_mm.allFinite() || !std::isfinite(o.a_deg) || !std::isfinite(o.c_deg))
      throw UsageError("centres: a number is not finite");
    out.push_back(o);
  }
  if (out.empty()) throw UsageError("centres: none");
  return out;
}

int RunKinematicsCommand(const std::vector<std::string>& args,
                         std::ostream& out,
                         std::ostream& err) {
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    out << kUsage;
    return kExitOk;
  }
  try {
    if (!args.empty() && args[0] == "plan") return Plan(args, out);
    if (!args.empty() && args[0] == "flange-pose") return FlangePose(args, out);
    if (!args.empty() && args[0] == "calibrate") return Calibrate(ParseCalibrate(args), out, err);
    return Check(Parse(args), out, err);
  } catch (const UsageError& e) {
    err << "mlp kinematics: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  }
}

}  // namespace mlp::host
