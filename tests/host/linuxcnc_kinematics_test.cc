// The trunnion check end to end on the real LinuxCNC (issue 54): the five-axis sample
// (samples/linuxcnc/mlprobe-5axis) runs the program `mlp kinematics plan` wrote; at each stop
// M101 reads the five joints and the kinematics' pins from HAL and asks mlp-hostd for a capture
// in the machine frame; the virtual probe renders the reference sphere where the machine's TRUE
// axes put it at the joints it reads from HAL (a machine file: pivots tens of micrometres off
// the pins, A 0.01 deg out of square, which the controller's kinematics cannot hold); the
// service's kinematics job fits each capture's sphere through the calibrated as-built probe
// and the axes' lines, and reports each pivot and the squareness against the pins.

#include "mlp/base/json_fields.h"
#include "mlp/calib/trunnion_hal.h"
#include "mlp/history/history.h"
#include "mlp/host/demo_command.h"
#include "mlp/sim/machine_world.h"
#include "mlp/sim/render.h"

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "hostd_site.h"
#include "linuxcnc_machine.h"
#include "test_data.h"

namespace mlp {
namespace {

namespace fs = std::filesystem;
using test::Child;
using test::json;
using test::Site;

constexpr int kPort = 17484;
constexpr double kPivotTolMm = 0.002;       // issue 54: each pivot found within 2 um
constexpr double kSquareTolDeg = 0.002;     // and the squareness within 0.002 deg
constexpr double kSphereRadiusMm = 12.7;    // the reference sphere (CalibrateThroughChain's)
constexpr double kHandEyeTolUm = 5.0;       // issue 54: the hand-eye on the trunnion within
constexpr double kHandEyeTolArcsec = 10.0;  // 5 um and 10 arcsec
constexpr double kGrowthMm = 0.008;         // the warm-up's growth of C's position in X
constexpr double kDriftTolMm = 0.001;       // a drift between two checks found within 1 um
constexpr double kReadoutMm = 1e-4;         // halcmd prints a pin to 7 digits: 0.1 um at 100-999 mm

// The machine as it truly is, against the sample's pins (trunnion.hal: C through (120, -40),
// A through (y, z) = (-37.5, -90)): C 30 um off in X and -20 um in Y, A +25 um in Y and -35 um
// in Z, A turned 0.01 deg about Z.
const geometry::Vec3 kTrueCMm(120.030, -40.020, 0.0);
const geometry::Vec3 kTrueAMm(0.0, -37.475, -90.035);
constexpr double kAAboutZDeg = 0.01;
// What those are in the pins' terms (found - pin), as `mlp kinematics check` names them: the
// lines where they pass each other (the common perpendicular), so A's y is taken at C's x, where
// its 0.01 deg turn about Z has moved it 120.03 mm x tan(0.01 deg) = 20.9 um from its y at x = 0.
std::map<std::string, double> PinErrorsMm() {
  const double a_y_at_c = kTrueAMm.y() + kTrueCMm.x() * std::tan(kAAboutZDeg * M_PI / 180);
  return {{"x-rot-point", kTrueCMm.x() - 120.0},
          {"y-rot-point", kTrueCMm.y() + 40.0},
          {"y-offset", (a_y_at_c - kTrueCMm.y()) - 2.5},
          {"z-offset", kTrueAMm.z() + 90.0}};
}

std::string ReadHostLog(const Site& site) { return test::ReadText(site.dir / "hostd.log"); }

const geometry::Vec3 kSphereOnTableMm(180.0, -40.0, -40.0);  // 60 mm off C

json TrueMachine(const geometry::Vec3& c_grown_mm = geometry::Vec3::Zero()) {
  const double t = kAAboutZDeg * M_PI / 180;
  const geometry::Vec3 c = kTrueCMm + c_grown_mm;
  return {{"format", "mlprobe-machine/1"},
          {"kind", "trunnion"},
          {"a_axis",
           {{"point_mm", {kTrueAMm.x(), kTrueAMm.y(), kTrueAMm.z()}},
            {"direction", {std::cos(t), std::sin(t), 0.0}}}},
          {"c_axis", {{"point_mm", {c.x(), c.y(), c.z()}}, {"direction", {0, 0, 1}}}}};
}

// The sphere on the table, the probe mounted as on the demo plate (the hand-eye's machine), and
// one capture straight above it (its window's projector columns are every stop's: the probe
// sees the sphere the same way from each).
json SphereOnTable(const geometry::Pose3& table_from_flange) {
  json scene = json::parse(test::ReadText(test::kDemoPlate));
  const json mount = scene.at("flange_from_probe");
  return {
      {"format", "mlprobe-scene/1"},
      {"flange_from_probe", mount},
      {"workpiece",
       {{"sphere",
         {{"center", {kSphereOnTableMm.x(), kSphereOnTableMm.y(), kSphereOnTableMm.z()}},
          {"radius", kSphereRadiusMm}}},
        {"reflectance", 0.6}}},
      {"captures",
       {{{"id", "above"}, {"mcs_from_flange", base::json_fields::PoseToJson(table_from_flange)}}}}};
}

// The hand-eye's poses: at each (A, C) the gauge point that puts the sphere at `in_view` in the
// probe frame of a flange T(g) Rz(spindle) Rx(180) (the mounting the scene's), taken by M101 P<n>
// in the table's frame. The captures' names.
std::vector<std::string> HandEyeViews(const test::LinuxCnc& cnc,
                                      const fs::path& config,
                                      const sim::VirtualProbe& seen,
                                      const sim::TrunnionWorld& nominal) {
  const geometry::Pose3 mount = seen.scene().flange_from_probe;
  std::ostringstream program;
  program.precision(10);
  program << "G21 G90 G40\nM68 E3 Q1\nM66 E0 L0\nG53 G0 Z250\n";
  std::vector<std::string> names;
  int k = 0;
  for (const double a : {0.0, 30.0, -30.0, 60.0}) {
    for (const double c : {0.0, 90.0, 180.0, 270.0}) {
      const double spindle = std::fmod(110.0 * k, 360.0);  // M19 R takes 0..360
      const geometry::Vec3 in_view(4.0 * std::cos(1.9 * k), 3.0 * std::sin(2.3 * k),
                                   118.0 + 8.0 * std::sin(1.3 * k));
      geometry::Pose3 flange = geometry::Pose3::Identity();
      flange.linear() = (Eigen::AngleAxisd(spindle * M_PI / 180, geometry::Vec3::UnitZ()) *
                         Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()))
                            .toRotationMatrix();
      // TableFromFlange = MachineFromTable^-1 Rx(180) at the origin: its value at (0, 0) over
      // its value at (a, c) is the table's motion.
      const geometry::Pose3 machine_from_table =
          nominal.TableFromFlange({geometry::Vec3::Zero(), 0.0, 0.0, 0.0}) *
          nominal.TableFromFlange({geometry::Vec3::Zero(), a, c, 0.0}).inverse();
      const geometry::Vec3 sphere = machine_from_table * kSphereOnTableMm;
      const geometry::Vec3 g = sphere - flange.linear() * (mount * in_view);
      flange.translation() = g;
      sim::Capture view;
      view.id = "he_" + std::to_string(k + 1);
      view.mcs_from_flange = machine_from_table.inverse() * flange;
      json job = host::SceneCaptureRequest("lcnc-1", seen, view, {824, 618, 400, 300});
      job.erase("mcs_from_flange");
      std::ofstream(config / "jobs" / (std::to_string(501 + k) + ".json")) << job.dump();
      names.push_back(view.id);
      program << "G53 G0 A" << a << " C" << c << "\nM19 R" << spindle << "\nG53 G0 X" << g.x()
              << " Y" << g.y() << "\nG53 G0 Z" << g.z() << "\nM101 P" << 501 + k
              << "\nG53 G0 Z250\n";
      ++k;
    }
  }
  program << "M68 E3 Q0\nM66 E0 L0\nM2\n";
  const json ran = cnc.Run(program.str());
  EXPECT_TRUE(ran.value("ended", false) && ran.at("errors").empty()) << ran.dump();
  return names;
}

// The kinematics job that calibrates from the sphere captures (M101's job file).
json CalibrationJob(const std::vector<std::string>& captures) {
  return {{"op", "kinematics"},
          {"machine", "lcnc-1"},
          {"captures", captures},
          {"sphere_radius_mm", kSphereRadiusMm},
          {"calibrate", true}};
}

// The kinematics job (a check, nothing written) on the sphere captures; its reply, whatever the
// status (out of tolerance exits 5), or {"error"} when the client printed nothing.
json CheckOn(const Site& site, const std::string& name, const std::vector<std::string>& captures) {
  const auto run = site.Mlp("request " +
                            site.Request(name, {{"op", "kinematics"},
                                                {"machine", "lcnc-1"},
                                                {"captures", captures},
                                                {"sphere_radius_mm", kSphereRadiusMm}}) +
                            " --json");
  return run.out.empty() ? json{{"error", run.err}} : json::parse(run.out);
}

// The calibrate job on the views, no centre given, H from `kinematics`. Its reply.
json CalibrateOn(const Site& site, const std::vector<std::string>& views, const char* kinematics) {
  const auto run = site.Mlp(
      "request " +
      site.Request(std::string("hand-eye-") + kinematics, {{"op", "calibrate"},
                                                           {"machine", "lcnc-1"},
                                                           {"captures", views},
                                                           {"sphere_radius_mm", kSphereRadiusMm},
                                                           {"kinematics", kinematics}}) +
      " --json");
  return run.out.empty() ? json{{"error", run.err}} : json::parse(run.out);
}

// A 60 x 60 x 30 block with a D30 through-bore, the bore's top centre nominally at (60, -40,
// -40) on the table, clamped kPartShiftMm off that and turned kPartTurnDeg about the bore's
// axis (which the bore cannot show; the alignment's side face does).
const geometry::Vec3 kBoreTopNominalMm(60.0, -40.0, -40.0);
const geometry::Vec3 kPartShiftMm(0.150, -0.080, 0.0);
constexpr double kPartTurnDeg = 0.15;
constexpr double kBoreDiameterMm = 30.0;
constexpr double kTiltedBoreTolMm = 0.005;    // issue 54: the 3+2 bore within 5 um of the truth
constexpr double kAlignTolMm = 0.005;         // the alignment's origin on the tilted part, as it
constexpr double kAlignTolDeg = 10.0 / 3600;  // and its turn, as issue 6's on a flat part

geometry::Mat3 PartTurn() {
  return Eigen::AngleAxisd(kPartTurnDeg * M_PI / 180, geometry::Vec3::UnitZ()).toRotationMatrix();
}

json BlockOnTable(const geometry::Pose3& mount) {
  const geometry::Vec3 c = kBoreTopNominalMm + kPartShiftMm;
  const Eigen::AngleAxisd m(mount.linear());
  const geometry::Vec3 mv = m.axis() * m.angle(), mt = mount.translation();
  json faces = json::array();  // the block: behind its six faces, turned about the bore's axis
  const std::array<geometry::Vec3, 4> sides = {geometry::Vec3(1, 0, 0), geometry::Vec3(-1, 0, 0),
                                               geometry::Vec3(0, 1, 0), geometry::Vec3(0, -1, 0)};
  for (const geometry::Vec3& n : sides) {
    const geometry::Vec3 out = PartTurn() * n, at = c + 30.0 * out;
    faces.push_back(
        {{"halfspace", {{"point", {at.x(), at.y(), at.z()}}, {"normal", {out.x(), out.y(), 0}}}},
         {"reflectance", 0.6}});
  }
  faces.push_back({{"halfspace", {{"point", {c.x(), c.y(), c.z()}}, {"normal", {0, 0, 1}}}},
                   {"reflectance", 0.6}});
  faces.push_back({{"halfspace", {{"point", {c.x(), c.y(), c.z() - 30}}, {"normal", {0, 0, -1}}}},
                   {"reflectance", 0.6}});
  return {{"format", "mlprobe-scene/1"},
          {"flange_from_probe",
           {{"translation_mm", {mt.x(), mt.y(), mt.z()}},
            {"rotation_vector_rad", {mv.x(), mv.y(), mv.z()}}}},
          {"workpiece",
           {{"difference",
             {{{"intersection", faces}},
              {{"cylinder",
                {{"base", {c.x(), c.y(), c.z() - 31}},
                 {"axis", {0, 0, 1}},
                 {"radius", kBoreDiameterMm / 2},
                 {"length", 32}}}}}}}},
          {"captures",  // a scene holds one capture at least; the served probe uses none
           {{{"id", "unused"},
             {"mcs_from_flange",
              {{"translation_mm", {c.x(), c.y(), c.z() + 150}},
               {"rotation_vector_rad", {M_PI, 0, 0}}}}}}}};
}

// Where the NC puts the probe, straight down (spindle at 0), with the table at A and C, to see
// `target` (the table's frame, nominal) from 118 mm along its view: the flange in the table's
// frame (what the virtual probe's capture job holds) and the gauge point in machine
// coordinates (what the program moves to).
struct Stop {
  double a_deg = 0, c_deg = 0;
  geometry::Pose3 table_from_flange = geometry::Pose3::Identity();
  geometry::Vec3 gauge_machine_mm = geometry::Vec3::Zero();
};

geometry::Pose3 MachineFromTable(const sim::TrunnionWorld& nominal, double a, double c) {
  return nominal.TableFromFlange({geometry::Vec3::Zero(), 0.0, 0.0, 0.0}) *
         nominal.TableFromFlange({geometry::Vec3::Zero(), a, c, 0.0}).inverse();
}

// The probe's view (its z) in the table's frame at A and C.
geometry::Vec3 ViewOnTable(const sim::TrunnionWorld& nominal,
                           const geometry::Pose3& mount,
                           double a,
                           double c) {
  const geometry::Mat3 down = Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()).toRotationMatrix();
  return MachineFromTable(nominal, a, c).linear().transpose() * down * mount.linear().col(2);
}

Stop StopFor(const sim::TrunnionWorld& nominal,
             const geometry::Pose3& mount,
             double a,
             double c,
             const geometry::Vec3& target_table_mm) {
  const geometry::Pose3 machine_from_table = MachineFromTable(nominal, a, c);
  const geometry::Mat3 down = Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()).toRotationMatrix();
  Stop s{a, c};
  s.table_from_flange.linear() = machine_from_table.linear().transpose() * down;
  const geometry::Vec3 probe_origin = target_table_mm - 118.0 * ViewOnTable(nominal, mount, a, c);
  s.table_from_flange.translation() =
      probe_origin - s.table_from_flange.linear() * mount.translation();
  s.gauge_machine_mm = machine_from_table * s.table_from_flange.translation();
  return s;
}

// The capture jobs of `stops` (files FIRST, FIRST + 1, ...) and the program's moves to them,
// each followed by M101 and a retract; the capture ids `prefix`1, 2, ...
std::vector<std::string> CaptureAt(const std::vector<Stop>& stops,
                                   const sim::VirtualProbe& seen,
                                   const fs::path& config,
                                   int first,
                                   const std::string& prefix,
                                   std::ostream& program) {
  std::vector<std::string> names;
  for (size_t k = 0; k < stops.size(); ++k) {
    sim::Capture shot;
    shot.id = prefix + std::to_string(k + 1);
    shot.mcs_from_flange = stops[k].table_from_flange;
    json job = host::SceneCaptureRequest("lcnc-1", seen, shot, {874, 668, 300, 200});
    job.erase("mcs_from_flange");
    const int file = first + static_cast<int>(k);
    std::ofstream(config / "jobs" / (std::to_string(file) + ".json")) << job.dump();
    names.push_back(shot.id);
    const geometry::Vec3& g = stops[k].gauge_machine_mm;
    program << "G53 G0 A" << stops[k].a_deg << " C" << stops[k].c_deg << "\nG53 G0 X" << g.x()
            << " Y" << g.y() << "\nG53 G0 Z" << g.z() << "\nM101 P" << file << "\nG53 G0 Z250\n";
  }
  return names;
}

json BoreNominal() {
  return {{"top_centre_mm", {kBoreTopNominalMm.x(), kBoreTopNominalMm.y(), kBoreTopNominalMm.z()}},
          {"diameter_mm", kBoreDiameterMm},
          {"depth_mm", 30}};
}

// The bore seen at A 30 and four turns of C: at each, the probe straight down (spindle at 0)
// with a point of the wall leaning towards it, 10 mm under the rim; the measure job through
// the fitted axes, its update_work moving G54 in X and Y; the program calls the result
// subroutine. Checks the bore and G54 against the truth; the bore's capture ids.
std::vector<std::string> MeasureTheTiltedBore(const test::LinuxCnc& cnc,
                                              const Site& site,
                                              const fs::path& config,
                                              const sim::TrunnionWorld& nominal,
                                              const fs::path& part) {
  const sim::VirtualProbe seen(probe_fw::LoadProbeModel(test::kCalibratedModel),
                               sim::LoadScene(part.string()));
  const geometry::Pose3 mount = seen.scene().flange_from_probe;
  std::ostringstream program;
  program.precision(10);
  program << "G21 G90 G40\nM68 E3 Q1\nM66 E0 L0\nG53 G0 Z250\nM19 R0\n";
  std::vector<Stop> stops;
  for (int k = 0; k < 4; ++k) {
    const double a = 30.0, c = 45.0 + 90.0 * k;
    const geometry::Vec3 view = ViewOnTable(nominal, mount, a, c);
    const geometry::Vec3 lean = geometry::Vec3(view.x(), view.y(), 0).normalized();
    stops.push_back(
        StopFor(nominal, mount, a, c,
                kBoreTopNominalMm + kBoreDiameterMm / 2 * lean - 10.0 * geometry::Vec3::UnitZ()));
  }
  const std::vector<std::string> names = CaptureAt(stops, seen, config, 601, "bore_", program);
  std::ofstream(config / "jobs" / "700.json") << json{
      {"op", "measure"},
      {"machine", "lcnc-1"},
      {"feature", "bore"},
      {"captures", names},
      {"kinematics", "fitted"},
      {"nominal", BoreNominal()},
      {"tolerance", {{"upper_mm", 0.02}, {"lower_mm", 0.02}}},
      {"update_work",
       {{"offset", 1}, {"axes", "xy"}}}}.dump();
  program << "M101 P700 (the bore, G54 from where it was found)\nM66 E0 L0\n"
          << "o<mlp_result> call\nM68 E3 Q0\nM66 E0 L0\nM2\n";
  const json ran = cnc.Run(program.str());
  EXPECT_TRUE(ran.value("ended", false) && ran.at("errors").empty())
      << ran.dump() << test::ReadText(site.dir / "hostd.log");
  if (!ran.value("ended", false) || !ran.at("errors").empty()) return {};
  history::History h((site.dir / "data" / "history.sqlite").string());
  const json reply = h.ExportJob(h.ListJobs({}).back().id).at("reply");
  const geometry::Vec3 truth = kBoreTopNominalMm + kPartShiftMm;
  std::printf(
      "3+2 bore (A 30, C 45..315): diameter %.4f (truth %.4f), centre %.4f %.4f (truth "
      "%.4f %.4f), %d points, arc %.0f deg; G54 %.4f %.4f (truth %.4f %.4f)\n",
      reply.at("diameter_mm").get<double>(), kBoreDiameterMm,
      reply.at("centre_mm")[0].get<double>(), reply.at("centre_mm")[1].get<double>(), truth.x(),
      truth.y(), reply.at("points").get<int>(), reply.at("arc_span_deg").get<double>(),
      ran.at("g5x_offset")[0].get<double>(), ran.at("g5x_offset")[1].get<double>(),
      kPartShiftMm.x(), kPartShiftMm.y());
  // The same captures through the controller's (calibrated) pins, for the record: A's 0.01 deg
  // is in every H there.
  const json by_pins = test::RequestOn(site, "bore-by-pins",
                                       {{"op", "measure"},
                                        {"machine", "lcnc-1"},
                                        {"feature", "bore"},
                                        {"captures", names},
                                        {"nominal", BoreNominal()},
                                        {"tolerance", {{"upper_mm", 0.02}, {"lower_mm", 0.02}}}});
  if (by_pins.contains("centre_mm"))
    std::printf("  through the controller's pins: diameter %.4f, centre %.4f %.4f\n",
                by_pins.at("diameter_mm").get<double>(), by_pins.at("centre_mm")[0].get<double>(),
                by_pins.at("centre_mm")[1].get<double>());
  EXPECT_NEAR(reply.at("diameter_mm").get<double>(), kBoreDiameterMm, kTiltedBoreTolMm);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(reply.at("centre_mm")[i].get<double>(), truth[i], kTiltedBoreTolMm) << i;
    EXPECT_NEAR(ran.at("g5x_offset")[i].get<double>(), kPartShiftMm[i], kTiltedBoreTolMm) << i;
  }
  return names;
}

// 3-2-1 on the tilted part (plane-line-point through the fitted axes): the top face seen at A
// 30 from two corners, the front face (the part's -Y) at the C that leans the view towards it,
// the bore as the point; G54 set with its rotation (G10 L2 R) by the result subroutine. The
// origin: on the top, on the front edge, level with the bore's axis.
void AlignOnTheTiltedPart(const test::LinuxCnc& cnc,
                          const Site& site,
                          const fs::path& config,
                          const sim::TrunnionWorld& nominal,
                          const fs::path& part,
                          const std::vector<std::string>& bore) {
  const sim::VirtualProbe seen(probe_fw::LoadProbeModel(test::kCalibratedModel),
                               sim::LoadScene(part.string()));
  const geometry::Pose3 mount = seen.scene().flange_from_probe;
  const geometry::Vec3& top = kBoreTopNominalMm;
  double front_c = 0, best = -1;  // the C whose view leans most towards +Y: the front face seen
  for (double c = 0; c < 360; c += 0.5) {
    const geometry::Vec3 v = ViewOnTable(nominal, mount, 30.0, c);
    if (v.y() / std::hypot(v.x(), v.y()) > best)
      best = v.y() / std::hypot(v.x(), v.y()), front_c = c;
  }
  std::ostringstream program;
  program.precision(10);
  program << "G21 G90 G40\nM68 E3 Q1\nM66 E0 L0\nG53 G0 Z250\nM19 R0\n";
  const std::vector<std::string> faces =
      CaptureAt({StopFor(nominal, mount, 30.0, 45.0, top + geometry::Vec3(20, 20, 0)),
                 StopFor(nominal, mount, 30.0, 135.0, top + geometry::Vec3(-20, 20, 0))},
                seen, config, 801, "top_", program);
  const std::vector<std::string> front =
      CaptureAt({StopFor(nominal, mount, 30.0, front_c, top + geometry::Vec3(-12, -30, -12)),
                 StopFor(nominal, mount, 30.0, front_c, top + geometry::Vec3(12, -30, -12))},
                seen, config, 811, "front_", program);
  const geometry::Vec3 front_nominal = top + geometry::Vec3(0, -30, 0);
  std::ofstream(config / "jobs" / "820.json")
      << json{{"op", "align"},
              {"machine", "lcnc-1"},
              {"method", "plane-line-point"},
              {"work_offset", 1},
              {"kinematics", "fitted"},
              {"expected_origin_mm", {front_nominal.x(), front_nominal.y(), front_nominal.z()}},
              {"plane_a",
               {{"captures", faces},
                {"nominal", {{"point_mm", {top.x(), top.y(), top.z()}}, {"normal", {0, 0, 1}}}}}},
              {"plane_b",
               {{"captures", front},
                {"nominal",
                 {{"point_mm", {front_nominal.x(), front_nominal.y(), front_nominal.z() - 12}},
                  {"normal", {0, -1, 0}},
                  {"band_mm", 0.5}}}}},
              {"hole_c", {{"captures", bore}, {"nominal", BoreNominal()}}}}
             .dump();
  program << "M101 P820 (3-2-1 on the tilted part)\nM66 E0 L0\n"
          << "o<mlp_result> call\nM68 E3 Q0\nM66 E0 L0\nM2\n";
  const json ran = cnc.Run(program.str());
  ASSERT_TRUE(ran.value("ended", false) && ran.at("errors").empty())
      << ran.dump() << test::ReadText(site.dir / "hostd.log");
  history::History h((site.dir / "data" / "history.sqlite").string());
  const json reply = h.ExportJob(h.ListJobs({}).back().id).at("reply");
  const geometry::Vec3 truth =
      kBoreTopNominalMm + kPartShiftMm + PartTurn() * geometry::Vec3(0, -30, 0);
  const json& g = ran.at("g5x_offset");
  std::printf(
      "3-2-1 on the tilted part (front face at C %.1f): origin %.4f %.4f %.4f (truth %.4f %.4f "
      "%.4f), turn %.5f deg (truth %.5f); G54 %.4f %.4f %.4f R%.5f\n",
      front_c, reply.at("origin_mm")[0].get<double>(), reply.at("origin_mm")[1].get<double>(),
      reply.at("origin_mm")[2].get<double>(), truth.x(), truth.y(), truth.z(),
      reply.at("rotation_z_deg").get<double>(), kPartTurnDeg, g[0].get<double>(),
      g[1].get<double>(), g[2].get<double>(), ran.at("g5x_rotation").get<double>());
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(reply.at("origin_mm")[i].get<double>(), truth[i], kAlignTolMm) << i;
    EXPECT_NEAR(g[i].get<double>(), truth[i], kAlignTolMm) << i;
  }
  EXPECT_NEAR(reply.at("rotation_z_deg").get<double>(), kPartTurnDeg, kAlignTolDeg);
  EXPECT_NEAR(ran.at("g5x_rotation").get<double>(), kPartTurnDeg, kAlignTolDeg);
}

TEST(LinuxCncTrunnion, TheCheckFindsEachPivotAndTheSquarenessThroughTheProbe) {
  ASSERT_EQ(test::RunProcess("command -v linuxcnc").exit_code, 0);
  Site site("linuxcnc_kinematics", kPort);
  fs::copy(test::SourceDir() + "/samples/linuxcnc", site.dir / "linuxcnc",
           fs::copy_options::recursive);
  const fs::path config = site.dir / "linuxcnc" / "mlprobe-5axis";
  test::UseLinuxCncConfig(site, config);
  json hostd_config = json::parse(test::ReadText(site.dir / "hostd.json"));
  for (auto& m : hostd_config.at("machines"))
    if (m.at("name") == "lcnc-1")
      m["controller"]["kinematics_hal"] = (config / "trunnion.hal").string();
  std::ofstream(site.dir / "hostd.json") << hostd_config.dump(1);
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  test::CalibrateThroughChain(site, "lcnc-1", kPort);
  if (HasFatalFailure()) return;

  // The plan from the pins the machine starts with, M101 P101... at its stops.
  const fs::path program = site.dir / "plan.ngc";
  const auto plan = test::RunProcess(
      test::kMlp + " kinematics plan --pins " + (config / "trunnion.hal").string() +
      " --sphere 180,-40,-40 --a -30,0,30,60 --c 3 --probe-length 35 --standoff 118 --json" +
      " --capture-jobs 101 --out " + program.string());
  ASSERT_EQ(plan.exit_code, 0) << plan.err;
  const json stops = json::parse(plan.out).at("stops");
  ASSERT_EQ(stops.size(), 12u);

  // Every stop's capture job: the window and columns of the first stop seen on the nominal
  // machine, the pose read by M101 in the machine frame.
  sim::TrunnionWorld nominal;
  nominal.a = {geometry::Vec3(0, -37.5, -90), geometry::Vec3::UnitX()};
  nominal.c = {geometry::Vec3(120, -40, 0), geometry::Vec3::UnitZ()};
  const json& s0 = stops[0];
  const geometry::Pose3 above =
      nominal.TableFromFlange({geometry::Vec3(s0["gauge_machine_mm"][0].get<double>(),
                                              s0["gauge_machine_mm"][1].get<double>(),
                                              s0["gauge_machine_mm"][2].get<double>()),
                               s0["a_deg"].get<double>(), s0["c_deg"].get<double>(), 0.0});
  const fs::path scene = site.dir / "sphere_on_table.json";
  std::ofstream(scene) << SphereOnTable(above).dump(1);
  const sim::VirtualProbe seen(probe_fw::LoadProbeModel(test::kCalibratedModel),
                               sim::LoadScene(scene.string()));
  json capture = host::SceneCaptureRequest("lcnc-1", seen, seen.scene().captures.front(),
                                           {824, 618, 400, 300});
  capture.erase("mcs_from_flange");
  capture["pose_frame"] = "machine";
  std::vector<std::string> names;
  for (size_t i = 0; i < stops.size(); ++i) {
    names.push_back("kin_" + std::to_string(i + 1));
    capture["capture_id"] = names.back();
    std::ofstream(config / "jobs" / (std::to_string(101 + i) + ".json")) << capture.dump();
  }

  // The virtual probe reads the joints from the running machine's HAL, as M101 does.
  const fs::path machine = site.dir / "true_machine.json";
  std::ofstream(machine) << TrueMachine().dump(1);
  test::LinuxCnc cnc(config, "mlprobe-5axis.ini",
                     "MLP=" + test::kMlp + " MLP_SOCKET=" + site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  std::vector<std::string> probe_args = {"/usr/bin/env", "HOME=" + (config / "home").string(),
                                         "RTAPI_UID=1000",
                                         "RTAPI_FIFO_PATH=" + (config / "rtapi" / "fifo").string()};
  for (const std::string& a : test::AsBuiltProbeArgs(site, scene.string(), kPort))
    probe_args.push_back(a);
  probe_args.insert(probe_args.end(), {"--machine", machine.string()});
  std::optional<Child> probe;
  probe.emplace(probe_args, site.dir / "sim.log");
  ASSERT_TRUE(test::ProbeConnected(site));
  // Another scene or machine file: the probe stopped, the host seeing it gone, a new one.
  const auto restart_probe = [&](const fs::path& with_scene, const char* log) {
    probe.reset();
    if (!site.WaitFor([&] {
          const auto st = site.Mlp("status --json");
          return st.exit_code == 0 &&
                 json::parse(st.out).at("probes").at(0).at("connected") == false;
        }))
      return false;
    probe_args = {probe_args.begin(), probe_args.begin() + 4};
    for (const std::string& a : test::AsBuiltProbeArgs(site, with_scene.string(), kPort))
      probe_args.push_back(a);
    probe_args.insert(probe_args.end(), {"--machine", machine.string()});
    probe.emplace(probe_args, site.dir / log);
    return test::ProbeConnected(site);
  };
  const json ran = cnc.Run(test::ReadText(program));
  ASSERT_TRUE(ran.value("ended", false)) << ran.dump() << test::ReadText(site.dir / "hostd.log");
  for (const json& e : ran.at("errors"))  // the program's own DEBUG lines say each stop
    ASSERT_EQ(e.get<std::string>().rfind(" mlp stop ", 0), 0u) << ran.dump();

  // The check: beyond the 10 um limit (the pins are 20-45 um off), each pivot's error found.
  const json reply = CheckOn(site, "check", names);
  EXPECT_EQ(reply.value("status", ""), "out_of_tolerance") << reply.dump(1);
  ASSERT_TRUE(reply.contains("pivots_mm")) << reply.dump(1);
  for (const json& s : reply.at("spheres"))
    std::printf(
        "  %s A %7.3f C %7.3f: centre %.4f %.4f %.4f, rms %.2f um, %d points, radius %.4f\n",
        s["capture"].get<std::string>().c_str(), s["a_deg"].get<double>(), s["c_deg"].get<double>(),
        s["centre_mm"][0].get<double>(), s["centre_mm"][1].get<double>(),
        s["centre_mm"][2].get<double>(), s["rms_mm"].get<double>() * 1e3, s["points"].get<int>(),
        s["free_radius_mm"].get<double>());
  for (const json& p : reply.at("pivots_mm")) {
    const std::string name = p.at("name");
    const double truth = PinErrorsMm().at(name);
    std::printf("pivot %s: found %+.2f um (truth %+.2f) +- %.2f\n", name.c_str(),
                p.at("error").get<double>() * 1e3, truth * 1e3, p.at("u").get<double>() * 1e3);
    EXPECT_NEAR(p.at("error").get<double>(), truth, kPivotTolMm) << name;
    EXPECT_FALSE(p.at("within").get<bool>()) << name;
  }
  for (const json& q : reply.at("squareness_deg")) {
    const std::string name = q.at("name");
    const double truth = name == "A from X about Z" ? kAAboutZDeg : 0.0;
    std::printf("square %s: found %+.4f deg (truth %+.4f) +- %.4f\n", name.c_str(),
                q.at("found").get<double>(), truth, q.at("u").get<double>());
    if (name == "A to C from square") continue;  // the same turn seen against C: checked above
    EXPECT_NEAR(q.at("found").get<double>(), truth, kSquareTolDeg) << name;
  }
  EXPECT_TRUE(fs::exists(reply.value("report", ""))) << reply.dump(1);
  if (HasFailure()) return;

  // `mlp kinematics calibrate` on the check's reply while the machine runs: the pins it would
  // write said, the file untouched (a running machine's pins are the job's, through M101).
  const std::string hal_at_check = test::ReadText(config / "trunnion.hal");
  const fs::path check_reply = site.dir / "check_reply.json";
  std::ofstream(check_reply) << reply.dump();
  std::string with_hal_env;
  for (size_t i = 0; i < 4; ++i) with_hal_env += probe_args[i] + " ";
  const auto cli = test::RunProcess(with_hal_env + test::kMlp + " kinematics calibrate --centres " +
                                    check_reply.string() + " --pins " +
                                    (config / "trunnion.hal").string() + " --write --json");
  EXPECT_EQ(cli.exit_code, 6) << cli.err << cli.out;
  EXPECT_NE(cli.err.find("LinuxCNC is running"), std::string::npos) << cli.err;
  const json cli_changes = json::parse(cli.out).at("changes");
  EXPECT_EQ(test::ReadText(config / "trunnion.hal"), hal_at_check);

  // The calibration from the same captures, through M101: refused under the trunnion's own
  // kinematics (nothing written), then in identity kinematics the pins written to the HAL file
  // and set on the running machine.
  const std::string hal_before = test::ReadText(config / "trunnion.hal");
  std::ofstream(config / "jobs" / "200.json") << CalibrationJob(names).dump();
  const json refused = cnc.Run("M101 P200\nM2\n");
  ASSERT_EQ(refused.at("errors").size(), 1u) << refused.dump();
  EXPECT_NE(refused.at("errors")[0].get<std::string>().find("identity kinematics"),
            std::string::npos)
      << refused.dump();
  EXPECT_EQ(test::ReadText(config / "trunnion.hal"), hal_before);
  const json calibrated = cnc.Run("M68 E3 Q1\nM66 E0 L0\nM101 P200\nM68 E3 Q0\nM66 E0 L0\nM2\n");
  ASSERT_TRUE(calibrated.at("errors").empty()) << calibrated.dump() << ReadHostLog(site);
  const std::map<std::string, double> nominal_pins = {
      {"x-rot-point", 120.0}, {"y-rot-point", -40.0}, {"y-offset", 2.5}, {"z-offset", 60.0}};
  const calib::TrtPins in_file = calib::ParseTrtPinsHal(test::ReadText(config / "trunnion.hal"));
  const std::map<std::string, double> file_pins = {{"x-rot-point", in_file.x_rot_point},
                                                   {"y-rot-point", in_file.y_rot_point},
                                                   {"y-offset", in_file.y_offset},
                                                   {"z-offset", in_file.z_offset}};
  for (const auto& [name, pin] : nominal_pins) {
    const auto live = cnc.Hal("-s getp xyzac-trt-kins." + name);
    ASSERT_EQ(live.exit_code, 0) << live.err;
    const double truth = pin + PinErrorsMm().at(name);
    std::printf("calibrated %s: %.4f live, %.4f in the file, truth %.4f\n", name.c_str(),
                std::stod(live.out), file_pins.at(name), truth);
    EXPECT_NEAR(std::stod(live.out), truth, kPivotTolMm) << name;
    EXPECT_NEAR(file_pins.at(name), std::stod(live.out), kReadoutMm) << name;
    for (const json& c : cli_changes) {  // the command's decision is the job's
      if (c.at("name") == name) {
        EXPECT_NEAR(c.at("after_mm").get<double>(), file_pins.at(name), 1e-7);
      }
    }
  }

  // The check again with a second plan from the new pins: the residual pivots under 2 um, and
  // a calibration from it changes nothing.
  const auto replan = test::RunProcess(
      test::kMlp + " kinematics plan --pins " + (config / "trunnion.hal").string() +
      " --sphere 180,-40,-40 --a -30,0,30,60 --c 3 --probe-length 35 --standoff 118" +
      " --capture-jobs 301 --out " + program.string());
  ASSERT_EQ(replan.exit_code, 0) << replan.err;
  std::vector<std::string> again;
  for (size_t i = 0; i < stops.size(); ++i) {
    again.push_back("kin2_" + std::to_string(i + 1));
    capture["capture_id"] = again.back();
    std::ofstream(config / "jobs" / (std::to_string(301 + i) + ".json")) << capture.dump();
  }
  const json reran = cnc.Run(test::ReadText(program));
  ASSERT_TRUE(reran.value("ended", false)) << reran.dump();
  // Still out of tolerance: A's 0.01 deg about Z is beyond the 0.01 deg limit and no pin can
  // hold it (the machine's service can); every pivot within 2 um.
  const json recheck = CheckOn(site, "recheck", again);
  EXPECT_EQ(recheck.value("status", ""), "out_of_tolerance") << recheck.dump(1);
  // The same machine checked twice: no drift beyond the checks' own scatter.
  ASSERT_TRUE(recheck.contains("drift") && recheck.at("drift").is_object()) << recheck.dump(1);
  for (const auto& [name, d] : recheck.at("drift").at("pivots_mm").items())
    EXPECT_LT(std::abs(d.get<double>()), kDriftTolMm) << name;
  ASSERT_TRUE(recheck.contains("pivots_mm")) << recheck.dump(1);
  for (const json& p : recheck.at("pivots_mm")) {
    std::printf("after calibration, pivot %s: %+.3f um +- %.2f\n",
                p.at("name").get<std::string>().c_str(), p.at("error").get<double>() * 1e3,
                p.at("u").get<double>() * 1e3);
    EXPECT_LT(std::abs(p.at("error").get<double>()), kPivotTolMm) << p.dump();
    EXPECT_TRUE(p.at("within").get<bool>()) << p.dump();
  }
  for (const json& q : recheck.at("squareness_deg")) {
    if (q.at("name") == "A from X about Z") {
      EXPECT_NEAR(q.at("found").get<double>(), kAAboutZDeg, kSquareTolDeg) << q.dump();
    }
  }
  const std::string hal_calibrated = test::ReadText(config / "trunnion.hal");
  std::ofstream(config / "jobs" / "400.json") << CalibrationJob(again).dump();
  const json unchanged = cnc.Run("M68 E3 Q1\nM66 E0 L0\nM101 P400\nM68 E3 Q0\nM66 E0 L0\nM2\n");
  ASSERT_TRUE(unchanged.at("errors").empty()) << unchanged.dump();
  EXPECT_EQ(test::ReadText(config / "trunnion.hal"), hal_calibrated);
  if (HasFailure()) return;

  // The sphere hand-eye on the trunnion's own poses (issue 54 item 3), no centre given: H in
  // the table's frame from the joints and the calibrated pins (M101, `mlp kinematics
  // flange-pose`); the probe straight down over the sphere at 12 tilts and turns, the spindle
  // oriented three ways, the sphere at another place in the view and range each time.
  // Through the controller's kinematics its H carry A's 0.01 deg, which no pin holds: the
  // captures' centres disagree and the hand-eye says so. Through the axes the kinematics job
  // fitted (their squareness too), from the same captures' joints: M within the issue's limits.
  const std::vector<std::string> views = HandEyeViews(cnc, config, seen, nominal);
  const json by_pins = CalibrateOn(site, views, "controller");
  ASSERT_TRUE(by_pins.value("ok", false)) << by_pins.dump(1);
  const test::MountError e_pins = test::MountErrorOf(by_pins.dump(), scene.string());
  std::printf(
      "hand-eye on the trunnion, H from the controller's pins: %.2f um, %.2f arcsec from "
      "the true M; warnings %s\n",
      e_pins.um, e_pins.arcsec, by_pins.at("warnings").dump().c_str());
  EXPECT_FALSE(by_pins.at("warnings").empty());
  const json he = CalibrateOn(site, views, "fitted");
  ASSERT_TRUE(he.value("ok", false)) << he.dump(1);
  const test::MountError e = test::MountErrorOf(he.dump(), scene.string());
  std::printf(
      "hand-eye on the trunnion, H from the fitted axes: %.2f um, %.2f arcsec from the "
      "true M; centres spread %.2f um RMS; warnings %s\n",
      e.um, e.arcsec, he.at("centre_spread_rms_mm").get<double>() * 1e3,
      he.at("warnings").dump().c_str());
  EXPECT_LT(e.um, kHandEyeTolUm);
  EXPECT_LT(e.arcsec, kHandEyeTolArcsec);
  EXPECT_TRUE(he.at("warnings").empty()) << he.at("warnings").dump();
  if (HasFailure()) return;

  // 3+2 (issue 54 item 2): a block clamped on the table 150 um and -80 um off its nominal, its
  // D30 bore measured with the table tilted A 30 deg and turned to C 45, 135, 225 and 315 deg
  // (the probe straight down sees a wall leaning 30 deg towards it each time), H through the
  // fitted axes; G54 (in the table's frame, LinuxCNC's TCP) moved by where the bore was found.
  const fs::path part = site.dir / "tilted_part.json";
  std::ofstream(part) << BlockOnTable(seen.scene().flange_from_probe).dump(1);
  ASSERT_TRUE(restart_probe(part, "sim-part.log"));
  const std::vector<std::string> bore = MeasureTheTiltedBore(cnc, site, config, nominal, part);
  if (HasFailure()) return;
  AlignOnTheTiltedPart(cnc, site, config, nominal, part, bore);
  if (HasFailure()) return;

  // Warm-up: the C axis grows 8 um in X (the machine, not the pins); the same check again
  // reports the drift since the last one.
  std::ofstream(machine) << TrueMachine(geometry::Vec3(kGrowthMm, 0, 0)).dump(1);
  ASSERT_TRUE(restart_probe(scene, "sim-warm.log"));
  const json warm_ran = cnc.Run(test::ReadText(program));  // kin2_* taken again
  ASSERT_TRUE(warm_ran.value("ended", false)) << warm_ran.dump();
  const json warm = CheckOn(site, "warm", again);
  ASSERT_TRUE(warm.contains("drift") && warm.at("drift").is_object()) << warm.dump(1);
  const json& drift = warm.at("drift").at("pivots_mm");
  std::printf(
      "warm-up drift since job %d: C x %+.2f um (truth %+.2f), C y %+.2f, A y %+.2f, A z "
      "%+.2f\n",
      warm.at("drift").at("since_job").get<int>(), drift.at("c_x").get<double>() * 1e3,
      kGrowthMm * 1e3, drift.at("c_y").get<double>() * 1e3, drift.at("a_y").get<double>() * 1e3,
      drift.at("a_z").get<double>() * 1e3);
  EXPECT_NEAR(drift.at("c_x").get<double>(), kGrowthMm, kDriftTolMm);
  for (const char* other : {"c_y", "a_y", "a_z"})
    EXPECT_LT(std::abs(drift.at(other).get<double>()), kDriftTolMm) << other;
}

}  // namespace
}  // namespace mlp
