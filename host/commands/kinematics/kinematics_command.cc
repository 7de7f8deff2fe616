#include "mlp/host/kinematics_command.h"

#include "mlp/base/json_fields.h"
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
    "                           [--out PROGRAM.ngc] [--json]\n"
    "  The stops of a sphere check (the sphere at X,Y,Z in the table's frame; A at each of\n"
    "  --a, default -30,0,30,60,90; C at N positions a turn, default 4) and an NC program that\n"
    "  moves to them in machine coordinates: retract to a clearance height above every stop\n"
    "  and the table's rim, turn there, move over, go down (it moves only: no capture yet).\n"
    "usage: mlp kinematics flange-pose (--pins HALFILE | --pin NAME=MM ...) --joints X,Y,Z,A,C\n"
    "                                  [--spindle DEG]\n"
    "  H, the spindle flange in the table's frame, from the joints and the pins (a capture's\n"
    "  mcs_from_flange: translation_mm and rotation_vector_rad, JSON); --pin takes the running\n"
    "  machine's values (halcmd getp xyzac-trt-kins.NAME), x-rot-point to z-offset, tool-offset.\n";

// One reported quantity: the pin's value, what the centres say, its uncertainty and limit.
struct Row {
  std::string name;
  double pin, found, u, limit;
  bool Within() const { return std::abs(found - pin) <= limit; }
};

std::vector<Row> PivotRows(const calib::TrunnionFit& fit,
                           const calib::TrtPins& pins,
                           double limit_mm) {
  const calib::TrtPins to = calib::PinsFor(fit, pins);
  return {
      {"x-rot-point", pins.x_rot_point, to.x_rot_point, fit.c_x_u_mm, limit_mm},
      {"y-rot-point", pins.y_rot_point, to.y_rot_point, fit.c_y_u_mm, limit_mm},
      {"y-offset", pins.y_offset, to.y_offset, std::hypot(fit.a_y_u_mm, fit.c_y_u_mm), limit_mm},
      {"z-offset", pins.z_offset, to.z_offset, fit.a_z_u_mm, limit_mm}};
}

std::vector<Row> SquareRows(const calib::TrunnionFit& fit, double limit_deg) {
  return {{"A from X about Z", 0, fit.a_about_z_deg, fit.a_about_z_u_deg, limit_deg},
          {"A from X about Y", 0, fit.a_about_y_deg, fit.a_about_y_u_deg, limit_deg},
          {"C from Z about X (A zero)", 0, fit.c_about_x_deg, fit.c_about_x_u_deg, limit_deg},
          {"C from Z about Y", 0, fit.c_about_y_deg, fit.c_about_y_u_deg, limit_deg},
          {"A to C from square", 0, fit.a_c_square_deg, fit.a_c_square_u_deg, limit_deg}};
}

json RowsJson(const std::vector<Row>& rows) {
  json out = json::array();
  for (const Row& r : rows) {
    out.push_back({{"name", r.name},
                   {"controller", r.pin},
                   {"found", r.found},
                   {"error", r.found - r.pin},
                   {"u", r.u},
                   {"limit", r.limit},
                   {"within", r.Within()}});
  }
  return out;
}

// A panel: data (x, y) in [x0, x1] x [y0, y1] drawn into a square of `size` px at (left, top).
struct Panel {
  double left, top, size, x0, x1, y0, y1;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * size; }
  double Y(double y) const { return top + size - (y - y0) / (y1 - y0) * size; }
};

// A square panel about the points (equal scales, 15 % margin).
Panel Around(const std::vector<std::pair<double, double>>& pts, double left, double top) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& [x, y] : pts)
    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  const double half = 0.65 * std::max({x1 - x0, y1 - y0, 1.0});
  const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
  return {left, top, 320, cx - half, cx + half, cy - half, cy + half};
}

const char* ColourOf(double a_deg) {
  static const char* const kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                         "#ff7f0e", "#8c564b", "#e377c2"};
  return kColours[static_cast<size_t>(std::lround(std::abs(a_deg))) % 7];
}

void Mark(std::ostringstream& s, double x, double y, const char* colour, const std::string& label) {
  s << "<path d='M" << Fixed(x - 6, 1) << ' ' << Fixed(y, 1) << "h12M" << Fixed(x, 1) << ' '
    << Fixed(y - 6, 1) << "v12' stroke='" << colour << "' stroke-width='2'/>\n";
  s << "<text x='" << Fixed(x + 8, 1) << "' y='" << Fixed(y - 8, 1) << "' font-size='11' fill='"
    << colour << "'>" << label << "</text>\n";
}

// One view of the centres: (u, v) picks the coordinates; the fitted axis' and the pins' points.
void View(std::ostringstream& s,
          const std::vector<calib::TrunnionObservation>& centres,
          int u,
          int v,
          const Vec3& fitted,
          const Vec3& pinned,
          double left,
          const std::string& title) {
  std::vector<std::pair<double, double>> pts;
  pts.reserve(centres.size() + 1);
  for (const auto& c : centres) pts.emplace_back(c.centre_machine_mm[u], c.centre_machine_mm[v]);
  pts.emplace_back(fitted[u], fitted[v]);
  const Panel p = Around(pts, left, 50);
  s << "<rect x='" << left << "' y='50' width='320' height='320' fill='none' stroke='#888'/>\n"
    << "<text x='" << left << "' y='40' font-size='13'>" << title << "</text>\n";
  for (const auto& c : centres) {
    s << "<circle cx='" << Fixed(p.X(c.centre_machine_mm[u]), 1) << "' cy='"
      << Fixed(p.Y(c.centre_machine_mm[v]), 1) << "' r='4' fill='" << ColourOf(c.a_deg)
      << "'><title>A " << Fixed(c.a_deg, 3) << " C " << Fixed(c.c_deg, 3) << "</title></circle>\n";
  }
  Mark(s, p.X(fitted[u]), p.Y(fitted[v]), "#000", "axis found");
  Mark(s, p.X(pinned[u]), p.Y(pinned[v]), "#888", "pins");
}

// Horizontal bars of errors [um] against +-limit.
void Bars(std::ostringstream& s,
          const std::vector<Row>& rows,
          double scale,
          const char* unit,
          double top) {
  constexpr double kLeft = 900, kHalf = 150;
  double worst = 0;
  for (const Row& r : rows) worst = std::max({worst, std::abs(r.found - r.pin), r.limit});
  const double k = kHalf / (worst * scale);
  const double lim = rows.front().limit * scale * k;
  s << "<path d='M" << Fixed(kLeft - lim, 1) << ' ' << top - 12 << "v" << 22 * rows.size() << "M"
    << Fixed(kLeft + lim, 1) << ' ' << top - 12 << "v" << 22 * rows.size()
    << "' stroke='#d62728' stroke-dasharray='4 3'/>\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const Row& r = rows[i];
    const double e = (r.found - r.pin) * scale, y = top + 22.0 * static_cast<double>(i);
    s << "<rect x='" << Fixed(kLeft + std::min(0.0, e * k), 1) << "' y='" << Fixed(y - 8, 1)
      << "' width='" << Fixed(std::abs(e * k), 1) << "' height='12' fill='"
      << (r.Within() ? "#2ca02c" : "#d62728") << "'/>\n"
      << "<text x='" << kLeft - kHalf - 10 << "' y='" << Fixed(y + 2, 1)
      << "' font-size='11' text-anchor='end'>" << r.name << ": " << Fixed(e, 2) << " " << unit
      << " +- " << Fixed(r.u * scale, 2) << "</text>\n";
  }
}

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

void PrintRows(
    std::ostream& out, const std::vector<Row>& rows, double scale, const char* unit, int decimals) {
  for (const Row& r : rows) {
    out << "  " << r.name << ": " << Fixed((r.found - r.pin) * scale, decimals) << " " << unit
        << " +- " << Fixed(r.u * scale, decimals) << " (limit " << Fixed(r.limit * scale, decimals)
        << ")" << (r.Within() ? "" : "  BEYOND") << "\n";
  }
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
  const std::vector<Row> pivots = PivotRows(fit, pins, c.limit_mm);
  const std::vector<Row> square = SquareRows(fit, c.square_limit_deg);
  bool within = true;
  for (const Row& r : pivots) within = within && r.Within();
  for (const Row& r : square) within = within && r.Within();
  if (!c.svg.empty()) WriteOutputFile(c.svg, TrunnionSvg(centres, fit, pins, c.limit_mm));
  if (c.json) {
    const calib::TrtPins to = calib::PinsFor(fit, pins);
    out << json{{"within", within},
                {"centres", centres.size()},
                {"residual_rms_mm", fit.residual_rms_mm},
                {"residual_mm", fit.residual_mm},
                {"pivots_mm", RowsJson(pivots)},
                {"squareness_deg", RowsJson(square)},
                {"pins_that_fit",
                 {{"x-rot-point", to.x_rot_point},
                  {"y-rot-point", to.y_rot_point},
                  {"y-offset", to.y_offset},
                  {"z-offset", to.z_offset}}}}
               .dump(2)
        << "\n";
  } else {
    out << "trunnion check over " << centres.size() << " sphere centres: residual "
        << Fixed(fit.residual_rms_mm * 1e3, 2) << " um RMS, worst "
        << Fixed(*std::max_element(fit.residual_mm.begin(), fit.residual_mm.end()) * 1e3, 2)
        << " um\n pivots against the pins (found - pin, k = 1):\n";
    PrintRows(out, pivots, 1e3, "um", 1);
    out << " squareness, which the kinematics cannot hold:\n";
    PrintRows(out, square, 1.0, "deg", 4);
    out << (within ? " within the limits\n"
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
std::string PlanProgram(const calib::TrunnionPlan& plan, const Vec3& sphere) {
  std::ostringstream p;
  const std::string clear = "G53 G0 Z" + Coordinate(plan.clear_gauge_z_mm) + "\n";
  p << "(mlprobe trunnion check: " << plan.stops.size() << " stops, the sphere at "
    << Coordinate(sphere.x()) << " " << Coordinate(sphere.y()) << " " << Coordinate(sphere.z())
    << " on the table; written by mlp kinematics plan)\n"
    << "G21 G90 G40\nM68 E3 Q1 (identity kinematics: X Y Z A C are the joints)\nM66 E0 L0\n"
    << clear;
  for (size_t i = 0; i < plan.stops.size(); ++i) {
    const calib::TrunnionStop& s = plan.stops[i];
    p << "(stop " << i + 1 << " of " << plan.stops.size() << ")\n"
      << "G53 G0 A" << Coordinate(s.a_deg) << " C" << Coordinate(s.c_deg) << "\n"
      << "G53 G0 X" << Coordinate(s.gauge_machine_mm.x()) << " Y"
      << Coordinate(s.gauge_machine_mm.y()) << "\n"
      << "G53 G0 Z" << Coordinate(s.gauge_machine_mm.z()) << "\n"
      << "(DEBUG, mlp stop " << i + 1 << " #5420 #5421 #5422 #5423 #5425)\n"
      << clear;
  }
  p << "M68 E3 Q0 (the trunnion's kinematics again)\nM66 E0 L0\nM2\n";
  return p.str();
}

int Plan(const std::vector<std::string>& args, std::ostream& out) {
  const Args a({args.begin() + 1, args.end()},
               ArgSpec({"--pins", "--sphere", "--a", "--c", "--spindle", "--probe-length",
                        "--standoff", "--table-radius", "--table-top", "--margin", "--out"},
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
  if (a.Has("--out")) WriteOutputFile(a.Text("--out"), PlanProgram(plan, sphere));
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
  const std::string prefix = "xyzac-trt-kins.";
  std::map<std::string, double> values;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::istringstream words(line.substr(0, line.find('#')));
    std::string verb, pin, value, extra;
    if (!(words >> verb) || verb != "setp" || !(words >> pin) || pin.rfind(prefix, 0) != 0)
      continue;
    if (!(words >> value) || (words >> extra))
      throw UsageError("pins: '" + line + "' is not setp PIN VALUE");
    const std::string name = pin.substr(prefix.size());
    if (!values.emplace(name, ParseNumber(pin, value)).second)
      throw UsageError("pins: " + pin + " is set twice");
  }
  const auto get = [&](const std::string& name, bool required) {
    const auto it = values.find(name);
    if (it != values.end()) return it->second;
    if (required) throw UsageError("pins: no setp " + prefix + name);
    return 0.0;
  };
  calib::TrtPins p;
  p.x_rot_point = get("x-rot-point", true), p.y_rot_point = get("y-rot-point", true);
  p.z_rot_point = get("z-rot-point", true), p.y_offset = get("y-offset", true);
  p.z_offset = get("z-offset", true), p.tool_offset = get("tool-offset", false);
  return p;
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

std::string TrunnionSvg(const std::vector<calib::TrunnionObservation>& centres,
                        const calib::TrunnionFit& fit,
                        const calib::TrtPins& pins,
                        double limit_mm) {
  const calib::TrunnionAxes nominal = calib::AxesOf(pins);
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='1120' height='420' "
       "font-family='sans-serif'>\n"
    << "<rect width='1120' height='420' fill='white'/>\n";
  std::vector<calib::TrunnionObservation> at_zero;
  for (const auto& c : centres)
    if (std::abs(c.a_deg) < 1e-6) at_zero.push_back(c);
  View(s, centres, 1, 2, fit.axes.a.point, nominal.a.point, 30,
       "seen along X: the centres turn about A (colour: A)");
  View(s, at_zero.empty() ? centres : at_zero, 0, 1, fit.axes.c.point, nominal.c.point, 380,
       "seen along Z at A = 0: the centres turn about C");
  s << "<text x='750' y='40' font-size='13'>pivot errors against +-" << Fixed(limit_mm * 1e3, 1)
    << " um (dashed)</text>\n";
  Bars(s, PivotRows(fit, pins, limit_mm), 1e3, "um", 80);
  s << "<text x='750' y='210' font-size='13'>centre residuals: RMS "
    << Fixed(fit.residual_rms_mm * 1e3, 2) << " um over " << centres.size() << "</text>\n";
  const double worst =
      std::max(1e-6, *std::max_element(fit.residual_mm.begin(), fit.residual_mm.end()));
  for (size_t i = 0; i < fit.residual_mm.size(); ++i) {
    const double h = 120.0 * fit.residual_mm[i] / worst;
    s << "<rect x='"
      << Fixed(750 + 340.0 * static_cast<double>(i) / static_cast<double>(fit.residual_mm.size()),
               1)
      << "' y='" << Fixed(360 - h, 1) << "' width='"
      << Fixed(300.0 / static_cast<double>(fit.residual_mm.size()), 1) << "' height='"
      << Fixed(h, 1) << "' fill='" << ColourOf(centres[i].a_deg) << "'/>\n";
  }
  s << "<text x='750' y='385' font-size='11'>tallest " << Fixed(worst * 1e3, 2)
    << " um</text>\n</svg>\n";
  return s.str();
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
