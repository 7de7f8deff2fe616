#include "mlp/host/kinematics_command.h"

#include "mlp/base/json_fields.h"
#include "mlp/calib/trunnion_hal.h"
#include "mlp/calib/trunnion_report.h"
#include "mlp/host/cli.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <sstream>

#include <nlohmann/json.hpp>

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
    throw UsageError("the commands are check, plan and flange-pose");
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

int Check(const Command& c, std::ostream& out, std::ostream& err) {
  const calib::TrtPins& pins = c.pins;
  const std::vector<calib::TrunnionObservation> centres =
      ParseTrunnionCentres(ReadInputFile(c.centres));
  calib::TrunnionFit fit;
  try {
    fit = calib::FitTrunnion(centres, calib::AxesOf(pins));
  } catch (const calib::TrunnionError& e) {
    err << "mlp kinematics: " << e.what() << "\n";
    return kExitUndetermined;
  }
  const calib::TrunnionLimits limits{c.limit_mm, c.square_limit_deg};
  const bool within = calib::TrunnionWithin(fit, pins, limits);
  if (!c.svg.empty()) WriteOutputFile(c.svg, calib::TrunnionSvg(centres, fit, pins, c.limit_mm));
  if (c.json) {
    out << calib::TrunnionReportJson(centres, fit, pins, limits).dump(2) << "\n";
  } else {
    out << calib::TrunnionReportText(centres, fit, pins, limits)
        << (within ? " within the limits\n"
                   : " BEYOND a limit: mlp kinematics calibrate (not built yet) or the machine's "
                     "service\n");
  }
  return within ? static_cast<int>(kExitOk) : static_cast<int>(kExitKinematicsOff);
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
  if (j.is_discarded() || !j.is_object() || j.value("format", "") != "mlprobe-trunnion-centres/1" ||
      !j.contains("centres") || !j["centres"].is_array())
    throw UsageError("centres: not a mlprobe-trunnion-centres/1 file");
  std::vector<calib::TrunnionObservation> out;
  for (const json& c : j["centres"]) {
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
    return Check(Parse(args), out, err);
  } catch (const UsageError& e) {
    err << "mlp kinematics: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  }
}

}  // namespace mlp::host
