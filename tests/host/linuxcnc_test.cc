// The real LinuxCNC (Debian linuxcnc-uspace, headless sim config in samples/linuxcnc/) running
// an NC program that calls a probing job through a user M-code: the job runs on mlp-hostd with
// the virtual probe's captures, its result subroutine reaches the running program, and the
// program's following moves use the new offset. An out-of-tolerance result aborts the program
// with a readable message and changes nothing. Checked through LinuxCNC's stat channel.

#include "mlp/history/history.h"
#include "mlp/link/transport.h"

#include <array>
#include <future>
#include <map>
#include <optional>
#include <random>

#include "electrode_site.h"
#include "hostd_site.h"
#include "linuxcnc_machine.h"
#include "test_data.h"
#include "tool_site.h"

namespace mlp {
namespace {

using test::Child;
using test::json;
using test::RunProcess;
using test::Site;
namespace fs = std::filesystem;
using namespace std::chrono_literals;

const std::string kConfig = mlp::test::SourceDir() + "/samples/linuxcnc/mlprobe-sim";
constexpr int kPort = 17433;              // this test's probe link
constexpr int kAlignPort = 17438;         // the alignment test's
constexpr int kPosePort = 17440;          // the controller-pose test's
constexpr int kDriftPort = 17459;         // the moved-capture test's
constexpr int kRelocatePort = 17464;      // the re-clamped electrode's (no probe: unused)
constexpr int kSharedTablePort = 17472;   // two machines on one table (no probe: unused)
constexpr int kKillPort = 17481;          // kills beside a running LinuxCNC (no probe: unused)
constexpr int kKillKindsPort = 17483;     // kills of every job kind beside LinuxCNC
constexpr double kDisturbanceMm = 0.005;  // 5x the M-code's 1 um pose drift limit
constexpr double kFaceHeightTolMm = 0.001;
constexpr double kOriginTolMm = 0.005;           // issue 6: alignment origin within 5 um
constexpr double kRotationTolDeg = 10.0 / 3600;  // and rotation within 10 arcsec
constexpr double kSameNumber = 1e-12;            // the table holds what the reply said
constexpr double kPositionTolMm = 0.001;         // the machine's position at a work coordinate
constexpr double kPoseExact = 1e-9;      // a pose the controller reported, turned into radians
constexpr double kExactMm = 1e-6;        // LinuxCNC keeps doubles; our G10 lines carry 0.1 um
constexpr double kRoundingMm = 0.00005;  // half the 0.1 um step of the G10 values

// A headless LinuxCNC with the M-codes' environment: the client and the host's socket.
class LinuxCnc : public test::LinuxCnc {
 public:
  LinuxCnc(const fs::path& config, const std::string& socket)
      : test::LinuxCnc(config, "mlprobe-sim.ini", "MLP=" + test::kMlp + " MLP_SOCKET=" + socket) {}
};

// The site's machine lcnc-1 pointed at a fresh copy of the sample LinuxCNC config (its tool
// table, its subroutine folder), and the scene's calibration stored: the config folder.
fs::path LinuxCncSite(const Site& site) {
  const fs::path config = site.dir / "mlprobe-sim";
  fs::copy(kConfig, config, fs::copy_options::recursive);
  test::UseLinuxCncConfig(site, config);
  return config;
}

// The hand-eye through the product's chain before the job (issue 16): a reference sphere
// mounted as `scene` mounts the probe (the demo plate's own sphere, or one beside the bore
// block), the as-built probe, the host with the calibrated model.
void CalibrateFor(const Site& site, const std::string& scene, int port) {
  if (scene == test::kDemoPlate) return test::CalibrateThroughChain(site, "lcnc-1", port);
  const std::string sphere = (site.dir / "sphere.json").string();
  std::ofstream(sphere) << test::ReferenceSphereScene(sim::LoadScene(scene).flange_from_probe,
                                                      geometry::Vec3(200, 100, -250))
                               .dump(1);
  test::CalibrateThroughChain(site, "lcnc-1", port, sphere);
}

// The NC program a shop writes: measure the bore, take the result, cut with tool 12 under
// cutter compensation. With G41 along +X the tool's centre runs one radius to the left (+Y).
const std::string kProgram =
    "G21 G90 G54 G40 G49\n"
    "M101 P1 (measure the bore before the finishing pass)\n"
    "M66 E0 L0 (the M-code ran: read on from here)\n"
    "o<mlp_result> call\n"
    "(MSG, bore status #<_mlp_status> diameter #<_mlp_diameter>)\n"
    "T12 M6\n"
    "G43 H12\n"
    "G0 X-20 Y-20 Z10\n"
    "G41 G1 X0 Y0 F2000\n"
    "G1 X20 Y0\n"
    "M2\n";

TEST(LinuxCnc, AProbingJobSetsTheToolOffsetTheNextCutUses) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  Site site("linuxcnc", kPort);
  const fs::path config = LinuxCncSite(site);
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  CalibrateFor(site, test::kScene, kPort);
  if (HasFatalFailure()) return;
  Child probe(test::AsBuiltProbeArgs(site, test::kScene, kPort), site.dir / "sim.log");
  ASSERT_TRUE(test::ProbeConnected(site));
  const auto captures = test::CaptureSceneViews(site, "lcnc-1", test::kScene, "bore_wall",
                                                {874, 668, 300, 200}, test::kCalibratedModel);
  ASSERT_EQ(captures.size(), 4u);
  std::ofstream(config / "jobs" / "1.json")
      << test::BoreMeasureJob(captures, 40.010).dump();  // in tol.
  std::ofstream(config / "jobs" / "2.json")
      << test::BoreMeasureJob(captures, 40.050).dump();  // out

  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  const json before = cnc.State();
  EXPECT_NEAR(before.at("tools").at("12").at("diameter").get<double>(), 9.998, kExactMm);

  const json after = cnc.Run(kProgram);
  ASSERT_TRUE(after.value("ended", false)) << after.dump();
  // What the service decided, from its history: the job's reply.
  history::History h((site.dir / "data" / "history.sqlite").string());
  const auto jobs = h.ListJobs({});
  const json reply = h.ExportJob(jobs.back().id).at("reply");
  ASSERT_EQ(reply.at("status"), "in_tolerance") << reply.dump();
  const double radius = reply.at("update").at("after_mm");
  EXPECT_NEAR(radius, 4.999 + reply.at("offset_change_mm").get<double>(), kSameNumber);
  std::printf("LinuxCNC: tool 12 diameter %.4f -> %.4f mm (bore %.4f mm); G41 path at Y %.4f\n",
              9.998, after.at("tools").at("12").at("diameter").get<double>(),
              reply.at("diameter_mm").get<double>(), after.at("position")[1].get<double>());
  EXPECT_NEAR(after.at("tools").at("12").at("diameter").get<double>(), 2 * radius, 2 * kRoundingMm);
  EXPECT_NEAR(after.at("tool_offset")[2].get<double>(), 101.2, kExactMm);  // G43 H12
  // The cut used the new radius: the compensated path runs one radius left of Y = 0.
  EXPECT_NEAR(after.at("position")[1].get<double>(), radius, kRoundingMm);
  EXPECT_NEAR(after.at("position")[0].get<double>(), 20.0, kRoundingMm);
  EXPECT_NEAR(after.at("position")[2].get<double>(), 10.0 + 101.2, kExactMm);

  // Out of tolerance: the program stops at the M-code with the reason; nothing changes.
  std::string abort_program = kProgram;
  abort_program.replace(abort_program.find("M101 P1"), 7, "M101 P2");
  const json aborted = cnc.Run(abort_program);
  const std::string errors = aborted.at("errors").dump();
  EXPECT_NE(errors.find("out of tolerance"), std::string::npos) << errors;
  EXPECT_NEAR(aborted.at("tools").at("12").at("diameter").get<double>(),
              after.at("tools").at("12").at("diameter").get<double>(), kExactMm);
  EXPECT_EQ(aborted.at("position"), after.at("position"));  // no move ran
}

// G54 through the controller: the demo plate aligned (face A, holes B and C) through M101, the
// subroutine's G10 L2 P1 ... R sets G54 with its rotation, and a move to the work origin lands
// on hole B's centre in machine coordinates.
TEST(LinuxCnc, AnAlignmentSetsG54TheProgramMovesIn) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0);
  Site site("linuxcnc_align", kAlignPort);
  const fs::path config = LinuxCncSite(site);
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  CalibrateFor(site, test::kDemoPlate, kAlignPort);
  if (HasFatalFailure()) return;
  Child probe(test::AsBuiltProbeArgs(site, test::kDemoPlate, kAlignPort), site.dir / "sim.log");
  ASSERT_TRUE(test::ProbeConnected(site));
  const probe_fw::Aoi aoi{874, 668, 300, 200};
  const std::string& model = test::kCalibratedModel;
  const auto face = test::CaptureSceneViews(site, "lcnc-1", test::kDemoPlate, "face_", aoi, model);
  const auto b = test::CaptureSceneViews(site, "lcnc-1", test::kDemoPlate, "b_wall", aoi, model);
  const auto c = test::CaptureSceneViews(site, "lcnc-1", test::kDemoPlate, "c_wall", aoi, model);
  std::ofstream(config / "jobs" / "1.json")
      << host::DemoPlateAlignRequest("lcnc-1", face, b, c).dump();
  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  const json after = cnc.Run(
      "G21 G90 G40 G49\n"
      "M101 P1 (align the plate)\n"
      "M66 E0 L0\n"
      "o<mlp_result> call\n"
      "G54\n"
      "G0 X0 Y0 (hole B, the work origin)\n"
      "G0 X0 Y60 (hole C: along the work Y axis)\n"
      "M2\n");
  ASSERT_TRUE(after.value("ended", false)) << after.dump();
  const json truth = json::parse(test::ReadText(test::kDemoPlate)).at("truth");
  const double angle = truth.at("work_rotation_z_deg").get<double>();
  std::printf("LinuxCNC G54 (%.4f, %.4f, %.4f) R%.4f; at work (0, 60): machine (%.4f, %.4f)\n",
              after.at("g5x_offset")[0].get<double>(), after.at("g5x_offset")[1].get<double>(),
              after.at("g5x_offset")[2].get<double>(), after.at("g5x_rotation").get<double>(),
              after.at("position")[0].get<double>(), after.at("position")[1].get<double>());
  // The controller's G54 is what the host found (to the G10 line's rounding); what the host
  // found through the chain is within issue 6's 5 um and 10 arcsec of the truth.
  history::History h((site.dir / "data" / "history.sqlite").string());
  const json reply = h.ExportJob(h.ListJobs({}).back().id).at("reply");
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(after.at("g5x_offset")[k].get<double>(), reply.at("origin_mm")[k].get<double>(),
                kRoundingMm);
    EXPECT_NEAR(reply.at("origin_mm")[k].get<double>(),
                truth.at("work_origin_mcs_mm")[k].get<double>(), kOriginTolMm);
  }
  EXPECT_NEAR(after.at("g5x_rotation").get<double>(), reply.at("rotation_z_deg").get<double>(),
              kRoundingMm);
  EXPECT_NEAR(reply.at("rotation_z_deg").get<double>(), angle, kRotationTolDeg);
  // Work (0, 60) is hole C's centre: machine 250 - 60 sin(a), 120 + 60 cos(a).
  const double a = angle * M_PI / 180;
  EXPECT_NEAR(after.at("position")[0].get<double>(), 250 - 60 * std::sin(a), kPositionTolMm);
  EXPECT_NEAR(after.at("position")[1].get<double>(), 120 + 60 * std::cos(a), kPositionTolMm);
}

// Captures at the pose the controller reports: the program moves over the demo plate's top face
// and orients the spindle (M19 R), M101 takes the capture there (the pose read from LinuxCNC's
// stat channel and the spindle's orientation pin), and the face is measured from the captures
// by name.
TEST(LinuxCnc, CapturesAtTheControllersPoseAndMeasuresByName) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0);
  Site site("linuxcnc_pose", kPosePort);
  const fs::path config = LinuxCncSite(site);
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  CalibrateFor(site, test::kDemoPlate, kPosePort);
  if (HasFatalFailure()) return;
  Child probe(test::AsBuiltProbeArgs(site, test::kDemoPlate, kPosePort), site.dir / "sim.log");
  ASSERT_TRUE(test::ProbeConnected(site));
  // Three spots on the plate's top face (z -310) clear of the holes, the probe 120 mm above
  // (the gauge point 35 mm above the camera), the spindle turned differently at each.
  const double spots[3][3] = {{240, 150, 0}, {330, 115, 90}, {330, 190, 200}};
  std::string program = "G21 G90 G40 G49\nG53 G0 Z-100\n";
  for (int k = 0; k < 3; ++k) {
    const std::string name = "top_" + std::to_string(k + 1);
    std::ofstream(config / "jobs" / (std::to_string(k + 1) + ".json"))
        << json{{"op", "capture"}, {"machine", "lcnc-1"},         {"capture_id", name},
                {"roi", "full"},   {"aoi", {924, 668, 200, 200}}, {"columns", {480, 560, 2}}}
               .dump();
    program += "G53 G0 X" + std::to_string(spots[k][0]) + " Y" + std::to_string(spots[k][1]) +
               "\nG53 G0 Z-155\nM19 R" + std::to_string(spots[k][2]) + "\nM101 P" +
               std::to_string(k + 1) + "\nM66 E0 L0\n";
  }
  std::ofstream(config / "jobs" / "4.json") << json{
      {"op", "measure"},
      {"machine", "lcnc-1"},
      {"feature", "face"},
      {"captures", {"top_1", "top_2", "top_3"}},
      {"nominal", {{"point_mm", {250, 120, -310}}, {"normal", {0, 0, 1}}}},
      {"tolerance",
       {{"upper_mm", 0.01}, {"lower_mm", 0.01}}}}.dump();
  program += "M101 P4\nM66 E0 L0\no<mlp_result> call\nM2\n";
  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  history::History h((site.dir / "data" / "history.sqlite").string());
  const size_t calibration_jobs = h.ListJobs({}).size();  // the hand-eye's captures and solve
  const json after = cnc.Run(program);
  ASSERT_TRUE(after.value("ended", false)) << after.dump();
  const auto jobs = h.ListJobs({});
  ASSERT_EQ(jobs.size(), calibration_jobs + 4) << after.dump();
  for (size_t k = 0; k < 3; ++k) {  // each capture's H is where the controller stood
    const json pose =
        h.ExportJob(jobs[calibration_jobs + k].id).at("request").at("mcs_from_flange");
    const double turn = spots[k][2] * M_PI / 180;
    EXPECT_NEAR(pose.at("translation_mm")[0].get<double>(), spots[k][0], kExactMm);
    EXPECT_NEAR(pose.at("translation_mm")[1].get<double>(), spots[k][1], kExactMm);
    EXPECT_NEAR(pose.at("translation_mm")[2].get<double>(), -155.0, kExactMm);
    EXPECT_NEAR(pose.at("rotation_vector_rad")[0].get<double>(), M_PI * std::cos(turn / 2),
                kPoseExact);
    EXPECT_NEAR(pose.at("rotation_vector_rad")[1].get<double>(), M_PI * std::sin(turn / 2),
                kPoseExact);
  }
  const json reply = h.ExportJob(jobs.back().id).at("reply");
  std::printf(
      "LinuxCNC poses: top face from 3 captures at the controller's pose: height %.3f um, "
      "%d points\n",
      reply.at("height_mm").get<double>() * 1e3, reply.at("points").get<int>());
  EXPECT_EQ(reply.at("status"), "in_tolerance") << reply.dump();
  EXPECT_NEAR(reply.at("height_mm").get<double>(), 0.0, kFaceHeightTolMm);
  // M5 releases the orientation: the probe's turn is unknown, so no capture is taken.
  const json refused = cnc.Run("G21 G90\nM5\nM101 P1\nM2\n");
  EXPECT_NE(refused.at("errors").dump().find("orient the spindle"), std::string::npos)
      << refused.dump();
  EXPECT_EQ(h.ListJobs({}).size(), calibration_jobs + 4);
}

// Issue 23: a capture whose pose moved while its frames were taken is refused. A test-only HAL
// block adds an offset to X's position feedback. The probe here is the test's own link: when
// the capture request reaches it (the M-code has read the pose before), the test moves X's
// feedback by kDisturbanceMm and only then answers with a cloud, so the pose after the frames
// differs. The M-code rejects the capture on the host and stops the program; the capture can
// never be used.
TEST(LinuxCnc, ACaptureTakenWhileTheMachineMovedIsRejected) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0);
  Site site("linuxcnc_drift", kDriftPort);
  const fs::path config = LinuxCncSite(site);
  test::SaveSceneCalibration(site, test::kDemoPlate);  // the test is the probe: no chain here
  std::ofstream(config / "disturb.hal")
      << "# test only: an offset on X's position feedback, set by the test during a capture\n"
         "unlinkp joint.0.motor-pos-fb\n"
         "loadrt sum2 names=mlp_disturb_x\n"
         "addf mlp_disturb_x servo-thread\n"
         "net Xpos => mlp_disturb_x.in0\n"
         "net mlp-x-fb mlp_disturb_x.out => joint.0.motor-pos-fb\n";
  std::string ini = test::ReadText(config / "mlprobe-sim.ini");
  const std::string hal_line = "HALFILE = orient_sim.hal\n";
  ASSERT_NE(ini.find(hal_line), std::string::npos);
  ini.replace(ini.find(hal_line), hal_line.size(), hal_line + "HALFILE = disturb.hal\n");
  std::ofstream(config / "mlprobe-sim.ini") << ini;
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  link::ProbeLinkConfig pc;
  pc.port = kDriftPort;
  pc.serial = "MLP-REF-0001";
  pc.key = link::Key{link::Bytes(32, 0xaa)};  // the site's probe.key
  link::ProbeLink probe(pc, [](const std::string&) {});
  probe.Start();
  ASSERT_TRUE(test::ProbeConnected(site));
  std::ofstream(config / "jobs" / "1.json")
      << json{{"op", "capture"}, {"machine", "lcnc-1"},         {"capture_id", "top_1"},
              {"roi", "full"},   {"aoi", {924, 668, 200, 200}}, {"columns", {480, 560, 2}}}
             .dump();
  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  std::future<json> program = std::async(std::launch::async, [&] {
    return cnc.Run("G21 G90\nG53 G0 X330 Y115\nG53 G0 Z-155\nM19 R90\nM101 P1\nM66 E0 L0\nM2\n");
  });
  // The event, not a delay: the capture request at the probe.
  const auto request = probe.NextRequest(std::chrono::seconds(60));
  ASSERT_TRUE(request.has_value());
  const auto setp = cnc.Hal("setp mlp_disturb_x.in1 " + std::to_string(kDisturbanceMm));
  ASSERT_EQ(setp.exit_code, 0) << setp.err;
  link::LinkCloud cloud;  // a patch of the plate's top face, 120 mm below the camera
  cloud.capture_id = request->capture_id;
  cloud.probe_serial = pc.serial;
  cloud.mcs_from_flange = request->mcs_from_flange;
  for (int i = 0; i < 100; ++i) {
    cloud.xyz.insert(cloud.xyz.end(), {double(i % 10), double(i / 10), 120.0});
    cloud.quality.push_back(1.0f);
  }
  ASSERT_EQ(probe.Submit(cloud), link::SubmitResult::kQueued);
  const json after = program.get();
  EXPECT_NE(after.at("errors").dump().find("the machine moved 0.0050 mm during capture top_1"),
            std::string::npos)
      << after.dump();
  history::History h((site.dir / "data" / "history.sqlite").string());
  const auto jobs = h.ListJobs({});
  ASSERT_EQ(jobs.size(), 1u);
  const json capture = h.ExportJob(jobs.front().id);
  EXPECT_EQ(capture.at("status"), "failed");
  EXPECT_NE(capture.at("reply").at("error").get<std::string>().find("rejected by the controller"),
            std::string::npos);
  // Never used, by name or by id; a second rejection finds no finished capture.
  const json measure = {{"op", "measure"},
                        {"machine", "lcnc-1"},
                        {"feature", "face"},
                        {"captures", {"top_1"}},
                        {"nominal", {{"point_mm", {250, 120, -310}}, {"normal", {0, 0, 1}}}},
                        {"tolerance", {{"upper_mm", 0.01}, {"lower_mm", 0.01}}}};
  const auto by_name = site.Mlp("request " + site.Request("m", measure));
  EXPECT_EQ(by_name.exit_code, 7);
  EXPECT_NE(by_name.err.find("failed: take it again"), std::string::npos) << by_name.err;
  json by_id = measure;
  by_id["captures"] = {jobs.front().id};
  const auto r = site.Mlp("request " + site.Request("m", by_id));
  EXPECT_NE(r.err.find("is not a finished capture"), std::string::npos) << r.err;
  const auto again = site.Mlp("request " + site.Request("r", {{"op", "reject_capture"},
                                                              {"machine", "lcnc-1"},
                                                              {"job_id", jobs.front().id},
                                                              {"reason", "again"}}));
  EXPECT_EQ(again.exit_code, 7);
  EXPECT_NE(again.err.find("is no finished capture on lcnc-1"), std::string::npos) << again.err;
}

// The electrode's description and its textures before and after a re-clamp (turned 0.002 deg
// about Z, shifted 0.03, -0.02, 0.015 mm) in the site's data/tools.
void ElectrodeTextures(const Site& site) {
  const std::string& electrode = test::kElectrode;
  fs::create_directories(site.dir / "data" / "tools");
  fs::copy_file(electrode, site.dir / "data" / "tools" / "electrode.json");
  const std::string render = test::kMlp + " tool render-texture --tool " + electrode + " --out " +
                             (site.dir / "data" / "tools").string();
  ASSERT_EQ(RunProcess(render + "/before --seed 1").exit_code, 0);
  ASSERT_EQ(RunProcess(render + "/after --seed 2 --rotation-deg 0.003,-0.004,0.002 --shift-mm "
                                "0.03,-0.02,0.015")
                .exit_code,
            0);
}

// The LinuxCNC site with the electrode as tool 30 in its table and its textures rendered: the
// config folder (the relocate tests beside the controller).
fs::path ElectrodeLinuxCncSite(const Site& site) {
  const fs::path config = LinuxCncSite(site);
  std::ofstream(config / "tool.tbl", std::ios::app)
      << "T30 P30 X0.01 Z60.0 D11.662 ;EDM electrode\n";
  ElectrodeTextures(site);
  return config;
}

// An EDM electrode re-clamped (seed 000 example 6): the relocate job through M101 finds it
// from its texture, its subroutine's G10 L1 sets tool 30's X, Y, Z (this machine has no C axis:
// the job writes what the machine has, the electrode clamped back within 0.01 deg of its turn),
// and G43 H30 puts the electrode's end where the program says: the spindle stands off by the
// offsets.
TEST(LinuxCnc, ARelocatedElectrodesOffsetsMoveTheNextBurn) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  Site site("linuxcnc_relocate", kRelocatePort);
  const fs::path config = ElectrodeLinuxCncSite(site);
  if (HasFatalFailure()) return;
  std::ofstream(config / "jobs" / "1.json") << test::RelocateJob("after").dump();
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  const json after = cnc.Run(
      "G21 G90 G54 G40 G49\n"
      "M101 P1 (find the re-clamped electrode)\n"
      "M66 E0 L0\n"
      "o<mlp_result> call\n"
      "T30 M6\n"
      "G43 H30\n"
      "G0 X0 Y0 Z10\n"
      "M2\n");
  ASSERT_TRUE(after.value("ended", false)) << after.dump();
  const json& t30 = after.at("tools").at("30");
  std::printf("LinuxCNC: electrode T30 X %.4f Y %.4f Z %.4f mm; spindle at (%.4f, %.4f, %.4f)\n",
              t30.at("x").get<double>(), t30.at("y").get<double>(), t30.at("z").get<double>(),
              after.at("position")[0].get<double>(), after.at("position")[1].get<double>(),
              after.at("position")[2].get<double>());
  constexpr double kRelocateTolMm = 0.0005;  // the relocation's own tolerance (relocate_test)
  EXPECT_NEAR(t30.at("x").get<double>(), 0.01 - 0.03, kRelocateTolMm);
  EXPECT_NEAR(t30.at("y").get<double>(), 0.02, kRelocateTolMm);
  EXPECT_NEAR(t30.at("z").get<double>(), 60.0 - 0.015, kRelocateTolMm);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(after.at("tool_offset")[static_cast<size_t>(a)].get<double>(),
                t30.at(std::string(1, "xyz"[a])).get<double>(), kExactMm);
  EXPECT_NEAR(after.at("position")[0].get<double>(), t30.at("x").get<double>(), kRoundingMm);
  EXPECT_NEAR(after.at("position")[1].get<double>(), t30.at("y").get<double>(), kRoundingMm);
  EXPECT_NEAR(after.at("position")[2].get<double>(), 10.0 + t30.at("z").get<double>(), kExactMm);
}

// Issue 48 item 5 on the real controller: two machines configured on one LinuxCNC tool table,
// the host writing it (write_tool_table), relocate jobs on both at once, round after round.
// Before, 8 of 160 writes were lost ("cannot replace .../tool.tbl: No such file": both lanes
// used one temporary name). A relocation moves the offsets by the re-clamp's shift each time it
// runs, so a lost write shows as a missing step: every job answers, both tools hold all
// kRounds steps, and LinuxCNC started on the table afterwards offsets by them.
TEST(LinuxCnc, TwoMachinesOnOneToolTableLoseNoWrite) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  Site site("linuxcnc_shared_table", kSharedTablePort);
  const fs::path config = LinuxCncSite(site);
  std::ofstream(config / "tool.tbl", std::ios::app)
      << "T30 P30 X0.01 Z60.0 D11.662 ;EDM electrode A\n"
      << "T31 P31 X0.01 Z60.0 D11.662 ;EDM electrode B\n";
  json hostd_config = json::parse(test::ReadText(site.dir / "hostd.json"));
  for (auto& m : hostd_config.at("machines"))
    if (m.at("name") == "lcnc-1") {
      m["controller"]["write_tool_table"] = true;
      json second = m;
      second["name"] = "lcnc-2";
      second["controller"]["result_dir"] = (config / "subs2").string();
      hostd_config["machines"].push_back(second);
      break;
    }
  std::ofstream(site.dir / "hostd.json") << hostd_config.dump(1);
  ElectrodeTextures(site);
  if (HasFatalFailure()) return;
  const auto job = [&](const std::string& machine, int tool) {
    json j = test::RelocateJob("after");
    j["machine"] = machine, j["tool_number"] = tool;
    return j;
  };
  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }));
  constexpr int kRounds = 20;  // a lost step is 30 um in X, 15 um in Z: over the tolerance
  for (int round = 0; round < kRounds; ++round) {
    const std::string a = site.Request("a" + std::to_string(round), job("lcnc-1", 30));
    const std::string b = site.Request("b" + std::to_string(round), job("lcnc-2", 31));
    auto first = std::async(std::launch::async, [&] { return site.Mlp("request " + a); });
    auto second = std::async(std::launch::async, [&] { return site.Mlp("request " + b); });
    const auto ra = first.get(), rb = second.get();
    EXPECT_EQ(ra.exit_code, 0) << "round " << round << ": " << ra.err;
    EXPECT_EQ(rb.exit_code, 0) << "round " << round << ": " << rb.err;
  }
  EXPECT_EQ(hostd.Stop(), 0);
  const std::string table = test::ReadText(config / "tool.tbl");
  LinuxCnc cnc(config, site.socket);
  ASSERT_TRUE(cnc.Up()) << test::ReadText(config / "linuxcnc.log");
  const json after = cnc.Run("G21 G90 G54 G40 G49\nT30 M6\nG43 H30\nT31 M6\nG43 H31\nM2\n");
  ASSERT_TRUE(after.value("ended", false)) << after.dump();
  constexpr double kRelocateTolMm = 0.0005;  // the relocation's own tolerance (relocate_test)
  for (const char* tool : {"30", "31"}) {
    const json& t = after.at("tools").at(tool);
    EXPECT_NEAR(t.at("x").get<double>(), 0.01 - kRounds * 0.03, kRounds * kRelocateTolMm)
        << "T" << tool << table;
    EXPECT_NEAR(t.at("y").get<double>(), kRounds * 0.02, kRounds * kRelocateTolMm)
        << "T" << tool << table;
    EXPECT_NEAR(t.at("z").get<double>(), 60.0 - kRounds * 0.015, kRounds * kRelocateTolMm)
        << "T" << tool << table;
  }
  EXPECT_NEAR(after.at("tool_offset")[2].get<double>(),
              after.at("tools").at("31").at("z").get<double>(), kExactMm);
}

// A host beside a running LinuxCNC that a test kills with SIGKILL (issue 48 item 4, issue 53:
// a kill -9 test per job kind on the real controller). The M-code's client is wrapped to mark
// the moment its request leaves (request.sent), so that a kill lands inside the job; the
// program the kill aborted is run again under the same request_id after a restart, as an
// operator would. Jobs go through M101 P1 (jobs/1.json); LinuxCNC's own G10 (the subroutine
// the host writes) changes its tool table and work offsets.
class KilledHost {
 public:
  KilledHost(Site& site, const fs::path& config)
      : site_(site),
        config_(config),
        sent_(site.dir / "request.sent"),
        client_(site.dir / "mlp-marked") {
    std::ofstream(client_) << "#!/bin/sh\ntouch " << sent_.string() << "\nexec " << test::kMlp
                           << " \"$@\"\n";
    fs::permissions(client_, fs::perms::owner_all);
  }

  /// Starts the host (again); true once it answers.
  bool StartHost() {
    hostd_.reset();
    // Built in place: a Child copied would stop the process when its temporary dies.
    hostd_.emplace(
        std::vector<std::string>{test::kHostd, "--config", (site_.dir / "hostd.json").string()},
        site_.dir / "hostd.log");
    return site_.WaitFor([&] { return site_.Mlp("status").exit_code == 0; });
  }
  /// Starts LinuxCNC with the marking client as its M-codes' `mlp`; true once it is up.
  bool StartLinuxCnc() {
    cnc_.emplace(config_, "mlprobe-sim.ini",
                 "MLP=" + client_.string() + " MLP_SOCKET=" + site_.socket);
    return cnc_->Up();
  }
  json State() { return cnc_->State(); }
  int StopHost() { return hostd_->Stop(); }

  /// `program` with `job` as M101 P1's request, not cut: LinuxCNC's state after it, and in
  /// `job_ms` the time from the request's leaving to the result subroutine's writing.
  json RunUncut(const json& job, const std::string& program, double* job_ms) {
    std::ofstream(config_ / "jobs" / "1.json") << job.dump();
    fs::remove(sent_);
    json state = cnc_->Run(program);
    *job_ms =
        std::chrono::duration<double, std::milli>(
            fs::last_write_time(config_ / "subs" / "mlp_result.ngc") - fs::last_write_time(sent_))
            .count();
    return state;
  }

  struct Round {
    json cut;    ///< LinuxCNC's state after the program the kill may have aborted
    json again;  ///< after the program run again under the same request_id
  };
  /// `job` through `program`, the host killed at a random instant up to 1.5 `job_ms` after
  /// the request left, started again, and `program` run again.
  Round KillAndRetry(const json& job,
                     const std::string& program,
                     double job_ms,
                     std::mt19937* rng) {
    std::ofstream(config_ / "jobs" / "1.json") << job.dump();
    fs::remove(sent_);
    auto first = std::async(std::launch::async, [&] { return cnc_->Run(program); });
    EXPECT_TRUE(site_.WaitFor([&] { return fs::exists(sent_); })) << "no request left";
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(
        std::uniform_real_distribution<double>(0, 1.5 * job_ms)(*rng)));
    hostd_->Stop(SIGKILL);
    Round r{first.get(), json()};
    EXPECT_TRUE(StartHost()) << test::ReadText(site_.dir / "hostd.log");
    r.again = cnc_->Run(program);
    return r;
  }

 private:
  Site& site_;
  fs::path config_, sent_, client_;
  std::optional<Child> hostd_;
  std::optional<test::LinuxCnc> cnc_;
};

// The M-code's program: the job, its result subroutine, the end.
const std::string kKillProgram =
    "G21 G90 G54 G40 G49\nM101 P1\nM66 E0 L0\no<mlp_result> call\nM2\n";

// The history after kills: no write left as an intent, and every request of `kind` written
// by exactly one job, whatever the kills cut.
void ExpectEachRequestWrittenOnce(const Site& site,
                                  const std::string& kind,
                                  const std::vector<std::string>& request_ids) {
  history::History h((site.dir / "data" / "history.sqlite").string());
  std::map<std::string, int> written_by_request;
  for (const auto& job : h.ListJobs({"lcnc-1", kind, {}, 10000})) {
    const json exported = h.ExportJob(job.id);
    bool wrote = false;
    for (const json& w : exported.at("offset_writes")) {
      EXPECT_NE(w.at("state"), "intent") << kind << " job " << job.id;
      wrote = wrote || w.at("state") == "written";
    }
    if (wrote) ++written_by_request[exported.at("request").value("request_id", "")];
  }
  for (const std::string& id : request_ids)
    EXPECT_EQ(written_by_request[id], 1) << kind << " request " << id;
}

// Issue 48 item 4 beside a running LinuxCNC: the relocate job through M101, the host killed
// at a random instant after the M-code's request left, the program aborted by the failed
// M-code, the host restarted and the program run again under the same request_id. Each request
// must move T30 by one re-clamp step, never two, never none, and the history keep no intent.
TEST(LinuxCnc, KillsOfTheHostInsideM101MoveTheElectrodeOncePerRequest) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  constexpr int kRounds = 8;
  constexpr double kShiftXMm = -0.03, kRelocateTolMm = 0.0005;  // relocate_test's
  Site site("linuxcnc_kill", kKillPort);
  const fs::path config = ElectrodeLinuxCncSite(site);
  if (HasFatalFailure()) return;
  KilledHost host(site, config);
  ASSERT_TRUE(host.StartHost());
  ASSERT_TRUE(host.StartLinuxCnc()) << test::ReadText(config / "linuxcnc.log");
  const auto t30_x = [](const json& state) { return state.at("tools").at("30").at("x"); };
  // An uncut request first: the step, and how long the job takes from the request's leaving.
  double x_mm = t30_x(host.State()).get<double>();
  double job_ms = 0;
  const json uncut = host.RunUncut(test::RelocateJob("after"), kKillProgram, &job_ms);
  ASSERT_TRUE(uncut.value("ended", false) && uncut.at("errors").empty()) << uncut.dump();
  ASSERT_NEAR(t30_x(uncut).get<double>() - x_mm, kShiftXMm, kRelocateTolMm);
  x_mm = t30_x(uncut).get<double>();
  std::mt19937 rng(4811);
  int aborted = 0;
  for (int round = 0; round < kRounds; ++round) {
    json job = test::RelocateJob("after");
    job["request_id"] = "lcnc-kill-" + std::to_string(round);
    const KilledHost::Round r = host.KillAndRetry(job, kKillProgram, job_ms, &rng);
    ASSERT_TRUE(r.cut.value("ended", false)) << r.cut.dump();
    aborted += !r.cut.at("errors").empty();
    ASSERT_TRUE(r.again.value("ended", false) && r.again.at("errors").empty())
        << "round " << round << ": " << r.again.dump() << test::ReadText(site.dir / "hostd.log");
    EXPECT_NEAR(t30_x(r.again).get<double>() - x_mm, kShiftXMm, kRelocateTolMm)
        << "round " << round << (r.cut.at("errors").empty() ? " (not cut)" : " (cut)");
    x_mm = t30_x(r.again).get<double>();
  }
  EXPECT_EQ(host.StopHost(), 0);
  history::History h((site.dir / "data" / "history.sqlite").string());
  int started = 0;
  for (const auto& job : h.ListJobs({"lcnc-1", "relocate", {}, 10000})) {
    ++started;
    const json exported = h.ExportJob(job.id);  // held: see KillsInsideRelocateJobs
    for (const json& w : exported.at("offset_writes")) EXPECT_NE(w.at("state"), "intent") << job.id;
  }
  std::printf(
      "kill -9 beside LinuxCNC: %d rounds, %d programs aborted by the kill, %d relocate "
      "jobs started; a job %.0f ms from the request\n",
      kRounds, aborted, started, job_ms);
  EXPECT_GT(aborted, 0);  // not vacuous: some kills cut the M-code's job
}

// Issue 53: the kill -9 test of every other job kind that writes, beside a running LinuxCNC, on
// one site (the demo plate through the calibrated chain, the tool camera's images): a bore
// measured in tolerance moves T12's radius wear by its correction (a request written twice
// shows as a double step), an alignment sets G54 (the same captures give the same G54, written
// once per request by the history), the tool camera sets T3's length and diameter (new and worn
// images by turns). Rounds take the three kinds in turn; each kill lands at a random instant
// of its job.
TEST(LinuxCnc, KillsOfTheHostInsideM101WriteOncePerRequestForEveryJobKind) {
  ASSERT_EQ(RunProcess("command -v linuxcnc").exit_code, 0)
      << "linuxcnc-uspace is not installed: bash scripts/install-deps.sh";
  constexpr int kRoundsPerKind = 4;
  constexpr double kStepTolMm = 0.0005;  // a diameter step: two G10 roundings of 0.05 um, doubled
  Site site("linuxcnc_kill_kinds", kKillKindsPort);
  const fs::path config = LinuxCncSite(site);
  std::ofstream(config / "tool.tbl", std::ios::app) << test::kToolT3;
  test::EndMillImages(site);
  if (HasFatalFailure()) return;
  KilledHost host(site, config);
  ASSERT_TRUE(host.StartHost());
  CalibrateFor(site, test::kDemoPlate, kKillKindsPort);
  if (HasFatalFailure()) return;
  std::map<std::string, json> jobs;
  {
    Child probe(test::AsBuiltProbeArgs(site, test::kDemoPlate, kKillKindsPort),
                site.dir / "sim.log");
    ASSERT_TRUE(test::ProbeConnected(site));
    const probe_fw::Aoi aoi{874, 668, 300, 200};
    const std::string& model = test::kCalibratedModel;
    const auto views = [&](const std::string& prefix) {
      return test::CaptureSceneViews(site, "lcnc-1", test::kDemoPlate, prefix, aoi, model);
    };
    jobs["align"] =
        host::DemoPlateAlignRequest("lcnc-1", views("face_"), views("b_wall"), views("c_wall"));
    // The plate's bore (59.9 mm) against 59.91 +-0.02: in tolerance, T12's radius corrected.
    const json truth = json::parse(test::ReadText(test::kDemoPlate)).at("truth");
    jobs["measure"] = test::BoreMeasureJob(views("bore_wall"), 59.91);
    jobs["measure"]["nominal"]["top_centre_mm"] = truth.at("bore_centre_mcs_mm");
    jobs["measure"]["nominal"]["depth_mm"] = 20;
    jobs["measure"]["nominal"]["band_mm"] = 0.5;
  }
  jobs["tool"] = test::ToolJob("tools/new");
  jobs["tool"]["accept_findings"] = true;  // the worn tool's 20 um is written, not refused
  ASSERT_TRUE(host.StartLinuxCnc()) << test::ReadText(config / "linuxcnc.log");
  const auto t12_d = [](const json& s) {
    return s.at("tools").at("12").at("diameter").get<double>();
  };
  // Uncut first: each kind's job time, T12's step, the G54 the captures give.
  std::map<std::string, double> job_ms;
  const double d0 = t12_d(host.State());
  const json measured = host.RunUncut(jobs["measure"], kKillProgram, &job_ms["measure"]);
  ASSERT_TRUE(measured.value("ended", false) && measured.at("errors").empty()) << measured.dump();
  const double step_mm = t12_d(measured) - d0;
  ASSERT_GT(std::abs(step_mm), 0.002) << "the correction must move T12: " << measured.dump();
  const json aligned = host.RunUncut(jobs["align"], kKillProgram, &job_ms["align"]);
  ASSERT_TRUE(aligned.value("ended", false) && aligned.at("errors").empty()) << aligned.dump();
  const json g54 = aligned.at("g5x_offset");
  const json tooled = host.RunUncut(jobs["tool"], kKillProgram, &job_ms["tool"]);
  ASSERT_TRUE(tooled.value("ended", false) && tooled.at("errors").empty()) << tooled.dump();
  // T3 as each folder of images sets it: the same images give the same length and diameter.
  const auto t3 = [](const json& s) {
    const json& t = s.at("tools").at("3");
    return std::pair{t.at("z").get<double>(), t.at("diameter").get<double>()};
  };
  std::map<std::string, std::pair<double, double>> t3_by_images{{"tools/new", t3(tooled)}};
  std::mt19937 rng(5311);
  int aborted = 0;
  double d_mm = t12_d(tooled);
  std::map<std::string, std::vector<std::string>> requests;
  for (int round = 0; round < 3 * kRoundsPerKind; ++round) {
    const std::string kind = std::array{"measure", "align", "tool"}[round % 3];
    json job = jobs[kind];
    if (kind == "tool") job["images"] = (round / 3) % 2 == 0 ? "tools/worn" : "tools/new";
    job["request_id"] = "lcnc-" + kind + "-kill-" + std::to_string(round);
    requests[kind].push_back(job["request_id"]);
    const KilledHost::Round r = host.KillAndRetry(job, kKillProgram, job_ms[kind], &rng);
    ASSERT_TRUE(r.cut.value("ended", false)) << r.cut.dump();
    aborted += !r.cut.at("errors").empty();
    const std::string what = kind + " round " + std::to_string(round) +
                             (r.cut.at("errors").empty() ? " (not cut)" : " (cut)");
    ASSERT_TRUE(r.again.value("ended", false) && r.again.at("errors").empty())
        << what << ": " << r.again.dump() << test::ReadText(site.dir / "hostd.log");
    // T12 moves by the correction on a measure request, once; by nothing on the others.
    const double expected_step_mm = kind == "measure" ? step_mm : 0.0;
    EXPECT_NEAR(t12_d(r.again) - d_mm, expected_step_mm, kStepTolMm) << what;
    d_mm = t12_d(r.again);
    if (kind == "tool" && !t3_by_images.emplace(job["images"], t3(r.again)).second) {
      EXPECT_NEAR(t3(r.again).first, t3_by_images[job["images"]].first, kExactMm) << what;
      EXPECT_NEAR(t3(r.again).second, t3_by_images[job["images"]].second, kExactMm) << what;
    }
    for (size_t k = 0; k < 3; ++k)
      EXPECT_NEAR(r.again.at("g5x_offset")[k].get<double>(), g54[k].get<double>(), kRoundingMm)
          << what;
  }
  EXPECT_EQ(host.StopHost(), 0);
  for (const auto& [kind, ids] : requests) ExpectEachRequestWrittenOnce(site, kind, ids);
  std::printf(
      "kill -9 beside LinuxCNC, every job kind: %d rounds, %d programs aborted by the kill; "
      "jobs of %.0f (measure), %.0f (align), %.0f (tool) ms; T12's step %.4f mm\n",
      3 * kRoundsPerKind, aborted, job_ms["measure"], job_ms["align"], job_ms["tool"], step_mm);
  EXPECT_GT(aborted, 0);  // not vacuous: some kills cut the M-code's job
}

}  // namespace
}  // namespace mlp
