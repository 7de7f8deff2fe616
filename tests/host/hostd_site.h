#pragma once
// A machine site for the host service's end-to-end tests, all real processes on real sockets and
// files: a folder with a configuration (machine "vmc-1" writing result files, machine
// "lcnc-1" with a LinuxCNC tool table), a probe key, mlp-hostd, a virtual probe on the probe
// link (`mlp-sim serve`) and the macro's client `mlp`.

#include "mlp/calib/record.h"
#include "mlp/host/demo_command.h"
#include "mlp/sim/render.h"
#include "mlp/sim/scene.h"

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <thread>

#include "child_process.h"
#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

namespace mlp::test {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

inline const std::string kMlp = mlp::test::Program("mlp"), kHostd = mlp::test::Program("mlp-hostd"),
                         kSim = mlp::test::Program("mlp-sim");
inline const std::string kProbe = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
inline const std::string kScene = mlp::test::SourceDir() + "/samples/scenes/bore_block.json";
// The probe as built (the virtual probe renders with it) and its calibration, made by the
// product's chain (the firmware and the host use only that): issue 16, docs/PROBE.md.
inline const std::string kAsBuilt =
    mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.json";
inline const std::string kCalibratedModel =
    mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.calibrated.json";
inline const std::string kDemoPlate = mlp::test::SourceDir() + "/samples/scenes/demo_plate.json";
constexpr int kLinkPort = 17431;  // each test that runs a probe link has its own port

// One folder per test: ctest may run the tests of this file at once.
struct Site {
  fs::path dir;
  std::string socket;
  explicit Site(const std::string& name, int port = kLinkPort)
      : dir(fs::temp_directory_path() / ("mlp_hostd_test_" + name)),
        socket((dir / "run" / "jobs.sock").string()) {
    fs::remove_all(dir);
    fs::create_directories(dir);
    std::ofstream(dir / "probe.key") << std::string(64, 'a') << "\n";
    fs::permissions(dir / "probe.key", fs::perms::owner_read | fs::perms::owner_write);
    std::ofstream(dir / "hostd.json")
        << json{{"format", "mlprobe-hostd/1"},
                {"data_dir", "data"},
                {"job_socket", "run/jobs.sock"},
                {"probe_link", {{"address", "127.0.0.1"}, {"port", port}}},
                {"capture_timeout_s", 60},
                {"probes", {{{"serial", "MLP-REF-0001"}, {"key_file", "probe.key"}}}},
                {"machines", json::array()}};
    json files_machine = {{"name", "vmc-1"},
                          {"probe", "MLP-REF-0001"},
                          {"controller", {{"kind", "files"}, {"result_dir", "out"}}}};
    json linuxcnc_machine = {
        {"name", "lcnc-1"},
        {"probe", "MLP-REF-0001"},
        {"controller", {{"kind", "linuxcnc"}, {"tool_table", "tool.tbl"}, {"result_dir", "lcnc"}}}};
    json config = json::parse(ReadText(dir / "hostd.json"));
    config["machines"] = {files_machine, linuxcnc_machine};
    std::ofstream(dir / "hostd.json") << config.dump(1);
    std::ofstream(dir / "tool.tbl") << "T12 P12 Z101.2 D9.998 ;finishing end mill\n"
                                    << "T99 P99 Z0 D0 ;mlprobe\n";
  }
  test::ProcessRun Mlp(const std::string& args) const {
    return RunProcess(kMlp + " " + args + " --socket " + socket);
  }
  std::string Request(const std::string& name, const json& j) const {
    const fs::path p = dir / (name + ".json");
    std::ofstream(p) << j.dump();
    return p.string();
  }
  /// Polls `ok` every 20 ms for up to a minute: events take 0.1-2 s on an idle machine; the
  /// bound is generous so that a busy machine (scripts/test-under-load.sh) passes too.
  bool WaitFor(const std::function<bool()>& ok) const {
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    for (; std::chrono::steady_clock::now() < deadline; std::this_thread::sleep_for(20ms))
      if (ok()) return true;
    return ok();
  }
};

// The site's machine lcnc-1 pointed at a LinuxCNC configuration folder: its tool table, its
// subroutine folder (subs/) for the result subroutines, and jobs/ for M101's job files.
inline void UseLinuxCncConfig(const Site& site, const fs::path& config) {
  json hostd_config = json::parse(ReadText(site.dir / "hostd.json"));
  for (auto& m : hostd_config.at("machines"))
    if (m.at("name") == "lcnc-1")
      m["controller"] = {{"kind", "linuxcnc"},
                         {"tool_table", (config / "tool.tbl").string()},
                         {"result_dir", (config / "subs").string()}};
  std::ofstream(site.dir / "hostd.json") << hostd_config.dump(1);
  fs::create_directories(config / "jobs");
  fs::create_directories(config / "subs");
}

// The probe's calibration as the scene mounts it (a hand-eye record in the site's store).
inline void SaveSceneCalibration(const Site& site, const std::string& scene = kScene) {
  calib::CalibrationRecord cal;
  cal.probe_serial = "MLP-REF-0001";
  cal.kind = calib::RecordKind::kHandEye;
  cal.flange_from_probe = sim::LoadScene(scene).flange_from_probe;
  calib::CalibrationStore((site.dir / "data" / "calibrations").string()).Save(cal);
}

// Waits until the virtual probe is connected to the service.
inline bool ProbeConnected(const Site& site) {
  return site.WaitFor([&] {
    const auto s = site.Mlp("status --json");
    return s.exit_code == 0 && json::parse(s.out).at("probes").at(0).at("connected") == true;
  });
}

// Waits until the service reports `machine` running `op` (the event a test that interrupts a
// job needs, rather than a delay that a busy machine outlasts).
inline bool MachineRuns(const Site& site, const std::string& machine, const std::string& op) {
  return site.WaitFor([&] {
    const auto s = site.Mlp("status --json");
    if (s.exit_code != 0) return false;
    const json status = json::parse(s.out);  // not in the loop's head: it would dangle
    for (const json& m : status.at("machines"))
      if (m.at("name") == machine && m.at("running") == op) return true;
    return false;
  });
}

// A request cut by kill -9 (issue 24 item 5, issue 48), then sent again: the host `start`
// gives takes the request and is killed at a random instant within 1.2 x `*job_ms` of it; then
// `after_kill`; then a new host (settling what the killed one announced) answers the request
// again under its request_id and is stopped. `*job_ms` follows a retry that ran: a repeat
// answered from the history takes milliseconds and would shrink the window to nothing.
struct KillRetry {
  test::ProcessRun retry;  ///< `mlp request FILE --json` to the new host
  int stop_code = -1;      ///< the new host's exit code on SIGTERM
};
inline KillRetry KillThenRetry(const Site& site,
                               const std::string& request_file,
                               const std::function<Child()>& start,
                               std::mt19937* rng,
                               double* job_ms,
                               const std::function<void()>& after_kill = {}) {
  {
    Child hostd = start();
    Child client({kMlp, "request", request_file, "--socket", site.socket}, site.dir / "client.log");
    const auto delay = std::uniform_real_distribution<double>(0, 1.2 * *job_ms)(*rng);
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(delay));
    hostd.Stop(SIGKILL);
  }
  if (after_kill) after_kill();
  Child hostd = start();
  const auto t0 = std::chrono::steady_clock::now();
  KillRetry r{site.Mlp("request " + request_file + " --json")};
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (r.retry.exit_code == 0 && !json::parse(r.retry.out).value("repeated", false)) *job_ms = ms;
  r.stop_code = hostd.Stop();
  return r;
}

// A request through `mlp request --json`: the reply, or {} after a failure the test reports.
inline json RequestOn(const Site& site, const std::string& name, const json& request) {
  const auto run = site.Mlp("request " + site.Request(name, request) + " --json");
  EXPECT_EQ(run.exit_code, 0) << name << ": " << run.out << run.err;
  return run.exit_code == 0 ? json::parse(run.out) : json::object();
}

// The captures a plan job planned, taken on `machine`: their capture job ids.
inline std::vector<std::int64_t> TakePlan(const Site& site,
                                          const std::string& machine,
                                          const std::string& name,
                                          const json& plan) {
  std::vector<std::int64_t> ids;
  for (const json& c : plan.at("captures")) {
    json capture = c;
    capture["op"] = "capture", capture["machine"] = machine;
    const json reply = RequestOn(site, name + "-" + c.at("capture_id").get<std::string>(), capture);
    if (reply.contains("job_id")) ids.push_back(reply.at("job_id"));
  }
  return ids;
}

// Every capture of `scene` whose id starts with `prefix`, taken through the service on
// `machine` (default AOI 300 x 200 px at the sensor's centre; every second column reaching
// it, as the host plans with the probe model `model`): the capture job ids in the scene's order.
inline std::vector<std::int64_t> CaptureSceneViews(const Site& site,
                                                   const std::string& machine,
                                                   const std::string& scene,
                                                   const std::string& prefix,
                                                   probe_fw::Aoi aoi = {874, 668, 300, 200},
                                                   const std::string& model = kProbe) {
  const sim::VirtualProbe vp(probe_fw::LoadProbeModel(model), sim::LoadScene(scene));
  std::vector<std::int64_t> captures;
  for (const sim::Capture& c : vp.scene().captures) {
    if (c.id.rfind(prefix, 0) != 0) continue;
    const auto run =
        site.Mlp("request " + site.Request(c.id, host::SceneCaptureRequest(machine, vp, c, aoi)));
    EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
    if (run.exit_code == 0) captures.push_back(json::parse(run.out).at("job_id"));
  }
  return captures;
}

// The sample block's D40 through-bore (30 mm deep) seen by four captures tilted 30 deg into it
// (the scene's bore_wall_* captures) on `machine`: their capture job ids.
inline std::vector<std::int64_t> CaptureBoreWalls(const Site& site, const std::string& machine) {
  return CaptureSceneViews(site, machine, kScene, "bore_wall");
}

// A capture of the sample block's top face on vmc-1 (probe straight down, 120 mm above).
inline json TopFaceCapture(const std::string& capture_id = "top") {
  return {{"op", "capture"},
          {"machine", "vmc-1"},
          {"capture_id", capture_id},
          {"mcs_from_flange",
           {{"translation_mm", {30, 30, 120}}, {"rotation_vector_rad", {M_PI, 0, 0}}}},
          {"roi", "full"},
          {"aoi", {924, 668, 200, 200}},
          {"columns", {480, 560, 2}}};
}

// Measure the sample bore on lcnc-1 against `nominal_mm` +-0.02, updating tool 12's radius wear
// (null band 2 um, upper tolerance limit 0.5 mm).
inline json BoreMeasureJob(const std::vector<std::int64_t>& captures, double nominal_mm) {
  return {
      {"op", "measure"},
      {"machine", "lcnc-1"},
      {"feature", "bore"},
      {"captures", captures},
      {"nominal", {{"top_centre_mm", {0, 0, 0}}, {"diameter_mm", nominal_mm}, {"depth_mm", 30}}},
      {"tolerance", {{"upper_mm", 0.02}, {"lower_mm", 0.02}}},
      {"update",
       {{"offset", 12},
        {"register", "radius_wear"},
        {"null_band_mm", 0.002},
        {"upper_limit_mm", 0.5}}}};
}

// A sphere scene for the hand-eye: the reference sphere (R 12.7) on the table, the probe mounted
// with a known M, captures from directions on a cone around the sphere with the spindle
// oriented differently each time (translations alone would not determine M and c).
inline constexpr int kSphereViews = 8;
inline json ReferenceSphereScene(const geometry::Pose3& flange_from_probe,
                                 const geometry::Vec3& centre) {
  json captures = json::array();
  for (int k = 0; k < kSphereViews; ++k) {
    const double tilt = (10.0 + 25.0 * (k % 3) / 2.0) * M_PI / 180,
                 az = k * 2 * M_PI / kSphereViews;
    const geometry::Vec3 view(std::sin(tilt) * std::cos(az), std::sin(tilt) * std::sin(az),
                              -std::cos(tilt));  // camera z: towards the sphere
    geometry::Pose3 mcs_from_probe = geometry::Pose3::Identity();
    const geometry::Vec3 x = view.unitOrthogonal();
    const double roll = 0.7 * k;  // spindle orientation (M19)
    const geometry::Vec3 xr = std::cos(roll) * x + std::sin(roll) * view.cross(x);
    mcs_from_probe.linear() << xr, view.cross(xr), view;
    // The sphere at different places in the view and distances: were it always on the optical
    // axis at one range, M's tilt would trade against its offset along the axis.
    const geometry::Vec3 in_view(4.0 * std::cos(1.9 * k), 3.0 * std::sin(2.3 * k),
                                 118.0 + 8.0 * std::sin(1.3 * k));
    mcs_from_probe.translation() = centre - mcs_from_probe.linear() * in_view;
    const geometry::Pose3 h = mcs_from_probe * flange_from_probe.inverse();
    const Eigen::AngleAxisd r(h.linear());
    const geometry::Vec3 rv = r.axis() * r.angle(), t = h.translation();
    captures.push_back({{"id", "sphere_" + std::to_string(k)},
                        {"mcs_from_flange",
                         {{"translation_mm", {t.x(), t.y(), t.z()}},
                          {"rotation_vector_rad", {rv.x(), rv.y(), rv.z()}}}}});
  }
  const Eigen::AngleAxisd m(flange_from_probe.linear());
  const geometry::Vec3 mv = m.axis() * m.angle(), mt = flange_from_probe.translation();
  return {{"format", "mlprobe-scene/1"},
          {"flange_from_probe",
           {{"translation_mm", {mt.x(), mt.y(), mt.z()}},
            {"rotation_vector_rad", {mv.x(), mv.y(), mv.z()}}}},
          {"workpiece",
           {{"sphere", {{"center", {centre.x(), centre.y(), centre.z()}}, {"radius", 12.7}}},
            {"reflectance", 0.6}}},
          {"captures", captures}};
}

// The virtual probe on the link rendering as built, its firmware given the calibrated model.
inline std::vector<std::string> AsBuiltProbeArgs(const Site& site,
                                                 const std::string& scene,
                                                 int port) {
  return {kSim,
          "serve",
          "--probe",
          kAsBuilt,
          "--firmware-model",
          kCalibratedModel,
          "--scene",
          scene,
          "--port",
          std::to_string(port),
          "--key",
          (site.dir / "probe.key").string()};
}

// How far a calibrate job's M (its reply, `calibrate_reply`) lies from the true M of the
// probe mounted as `scene` mounts it, in the calibrated model's probe frame (as the demo judges
// it; the window of the sphere captures, 400 x 300 px at the sensor's centre).
struct MountError {
  double um = 0, arcsec = 0;
};
inline MountError MountErrorOf(const std::string& calibrate_reply, const std::string& scene) {
  const json m = json::parse(calibrate_reply).at("flange_from_probe");
  const geometry::Vec3 t(m["translation_mm"][0].get<double>(), m["translation_mm"][1].get<double>(),
                         m["translation_mm"][2].get<double>());
  const geometry::Vec3 rv(m["rotation_vector_rad"][0].get<double>(),
                          m["rotation_vector_rad"][1].get<double>(),
                          m["rotation_vector_rad"][2].get<double>());
  const probe_fw::Aoi window{824, 618, 400, 300};
  const geometry::Pose3 truth =
      sim::LoadScene(scene).flange_from_probe *
      sim::TrueFromModelFrame(sim::LoadAsBuilt(kAsBuilt),
                              probe_fw::LoadProbeModel(kCalibratedModel), &window);
  const Eigen::AngleAxisd e(Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix() *
                            truth.linear().transpose());
  return {(t - truth.translation()).norm() * 1e3, e.angle() * 180 / M_PI * 3600};
}

// The hand-eye through the product's chain, as at the machine before a part is measured: the
// as-built probe looks at a reference sphere from the 8 poses of `sphere_scene` (its captures
// sphere_*; by default the demo plate's, whose mounting the features block shares: one virtual
// machine), the host plans with the calibrated model and solves on `machine`; the record is the
// service's own. The site's probe entry must name the calibrated model for plans. The
// calibration's probe is stopped before this returns.
inline void CalibrateThroughChain(const Site& site,
                                  const std::string& machine,
                                  int port,
                                  const std::string& sphere_scene = kDemoPlate) {
  {
    Child probe(AsBuiltProbeArgs(site, sphere_scene, port), site.dir / "sim-calibrate.log");
    ASSERT_TRUE(ProbeConnected(site));
    const auto ids = CaptureSceneViews(site, machine, sphere_scene, "sphere_", {824, 618, 400, 300},
                                       kCalibratedModel);
    ASSERT_EQ(ids.size(), 8u);
    const json request = {
        {"op", "calibrate"}, {"machine", machine}, {"captures", ids}, {"sphere_radius_mm", 12.7}};
    const auto run = site.Mlp("request " + site.Request("calibrate-chain", request) + " --json");
    ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
    const MountError e = MountErrorOf(run.out, sphere_scene);
    std::printf("hand-eye through the chain: %.2f um, %.2f arcsec from the true M\n", e.um,
                e.arcsec);
  }
  ASSERT_TRUE(site.WaitFor([&] {
    const auto s = site.Mlp("status --json");
    return s.exit_code == 0 && json::parse(s.out).at("probes").at(0).at("connected") == false;
  }));
}

}  // namespace mlp::test
