#include "mlp/host/demo_command.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/host/cli.h"
#include "mlp/service/job_client.h"
#include "mlp/sim/render.h"
#include "mlp/sim/scene.h"

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <random>
#include <sstream>
#include <thread>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include <unistd.h>

namespace mlp::host {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

constexpr const char* kUsage =
    "usage: mlp demo [--dir DIR] [--port N] [--samples DIR] [--json]\n"
    "  the whole job on the virtual machine: hand-eye calibration, plane-circle-circle\n"
    "  alignment -> G54, the bore before its finishing pass -> the finishing tool's radius\n"
    "  --dir      where the demo's service keeps its data (default: a new folder in /tmp)\n"
    "  --port     the probe link's port (default 17420)\n"
    "  --samples  the samples folder (default: ../../samples from this program, or ./samples)\n"
    "  --json     print what was found against the scene's truth as JSON\n"
    "exit codes: 0 done, 2 bad arguments, 7 a step failed (the reason is printed), 1 bug\n";
constexpr int kRequestTimeoutMs = 120000;
constexpr int kDemoTool = 12;

// A child process (the service, the virtual probe) with its stderr in a log file.
class Child {
 public:
  Child(const std::vector<std::string>& argv, const fs::path& log) {
    pid_ = fork();
    if (pid_ == 0) {
      // Both streams to the log: the demo's output is the demo's own.
      if (!std::freopen(log.c_str(), "w", stderr) || dup2(fileno(stderr), STDOUT_FILENO) < 0)
        _exit(126);
      std::vector<char*> a;
      a.reserve(argv.size() + 1);
      for (const auto& s : argv) a.push_back(const_cast<char*>(s.c_str()));
      a.push_back(nullptr);
      execv(a[0], a.data());
      _exit(127);
    }
  }
  ~Child() {
    if (pid_ <= 0) return;
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }

 private:
  pid_t pid_ = -1;
};

class DemoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::string RandomKeyHex() {
  std::random_device rd;
  std::string hex;
  char two[3];
  for (int i = 0; i < 32; ++i) {
    std::snprintf(two, sizeof two, "%02x", static_cast<unsigned>(rd() & 0xff));
    hex += two;
  }
  return hex;
}

struct Demo {
  fs::path dir, samples;
  int port = 17420;
  std::string socket;
  std::ostream& out;
  json summary = json::object();  ///< what was found against the truth (--json)
  /// Where the time went, summed over the demo's jobs [ms]: each capture's frames (the virtual
  /// probe renders them), firmware, link and host share, and the host's time in the other jobs.
  json time_ms = {{"frames", 0.0},       {"firmware", 0.0},  {"link", 0.0},
                  {"capture_host", 0.0}, {"jobs_host", 0.0}, {"captures", 0}};

  json Request(const json& r) {
    json reply = service::SendRequest(socket, r, kRequestTimeoutMs);
    if (!reply.value("ok", false) && reply.value("status", "") != "out_of_tolerance")
      throw DemoError(r.value("op", "?") + ": " + reply.value("error", std::string("failed")));
    if (reply.contains("timings_ms")) {
      const json& t = reply.at("timings_ms");
      for (const char* k : {"frames", "firmware", "link"})
        time_ms[k] = time_ms[k].get<double>() + t.at(k).get<double>();
      time_ms["capture_host"] = time_ms["capture_host"].get<double>() + t.at("host").get<double>();
      time_ms["captures"] = time_ms["captures"].get<int>() + 1;
    } else if (reply.contains("host_ms")) {
      time_ms["jobs_host"] = time_ms["jobs_host"].get<double>() + reply.at("host_ms").get<double>();
    }
    return reply;
  }

  // Every capture of the scene whose id starts with `prefix`, at its pose, with the AOI and the
  // columns a capture plan would give: the capture job ids.
  std::vector<std::int64_t> Capture(const sim::VirtualProbe& vp,
                                    const std::string& prefix,
                                    probe_fw::Aoi aoi) {
    std::vector<std::int64_t> ids;
    for (const sim::Capture& c : vp.scene().captures) {
      if (c.id.rfind(prefix, 0) != 0) continue;
      const json reply = Request(SceneCaptureRequest("demo-vmc", vp, c, aoi));
      out << "  " << std::left << std::setw(14) << c.id << std::right << std::setw(7)
          << reply.at("points").get<int>() << " points\n"
          << std::flush;
      ids.push_back(reply.at("job_id"));
    }
    return ids;
  }
};

void WriteSite(const Demo& d) {
  fs::create_directories(d.dir / "subs");
  const fs::path key = d.dir / "probe.key";
  std::ofstream(key) << RandomKeyHex() << "\n";
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  fs::copy_file(d.samples / "linuxcnc" / "mlprobe-sim" / "tool.tbl", d.dir / "tool.tbl",
                fs::copy_options::overwrite_existing);
  const json config = {{"format", "mlprobe-hostd/1"},
                       {"data_dir", "data"},
                       {"job_socket", "run/jobs.sock"},
                       {"probe_link", {{"address", "127.0.0.1"}, {"port", d.port}}},
                       {"probes", {{{"serial", "MLP-REF-0001"}, {"key_file", "probe.key"}}}},
                       {"machines",
                        {{{"name", "demo-vmc"},
                          {"probe", "MLP-REF-0001"},
                          {"controller",
                           {{"kind", "linuxcnc"},
                            {"tool_table", "tool.tbl"},
                            {"write_tool_table", true},
                            {"result_dir", "subs"}}}}}}};
  std::ofstream(d.dir / "hostd.json") << config.dump(1);
}

void WaitFor(const std::function<bool()>& ok, const std::string& what) {
  for (int i = 0; i < 300; ++i, std::this_thread::sleep_for(20ms))
    if (ok()) return;
  throw DemoError(what);
}

Eigen::Vector3d Vec(const json& j) {
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// The window the sphere's captures read.
const probe_fw::Aoi kSphereAoi{824, 618, 400, 300};

// `truth`: the true M in the calibrated model's probe frame (sim::TrueFromModelFrame).
void Calibrate(Demo& d, const sim::VirtualProbe& vp, const geometry::Pose3& truth) {
  d.out << "1. hand-eye calibration: the reference sphere from 8 poses\n";
  const auto ids = d.Capture(vp, "sphere_", kSphereAoi);
  const json r = d.Request({{"op", "calibrate"},
                            {"machine", "demo-vmc"},
                            {"captures", ids},
                            {"sphere_radius_mm", 12.7}});
  const Eigen::Vector3d t = Vec(r.at("flange_from_probe").at("translation_mm"));
  const Eigen::Vector3d rv = Vec(r.at("flange_from_probe").at("rotation_vector_rad"));
  const Eigen::AngleAxisd e(Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix() *
                            truth.linear().transpose());
  d.out << std::fixed << std::setprecision(4) << "   M translation (" << t.x() << ", " << t.y()
        << ", " << t.z() << ") mm: " << std::setprecision(2)
        << (t - truth.translation()).norm() * 1e3 << " um from the true mounting, rotation "
        << e.angle() * base::kArcsecPerRad << " arcsec (the true M in the calibrated probe frame, "
        << "which is rigidly like the true camera's to "
        << d.summary["calibration"]["frame_rms_um"].get<double>() << " um RMS); stored as "
        << r.at("calibration_id").get<std::string>() << "\n";
  d.summary["calibration"]["translation_error_um"] = (t - truth.translation()).norm() * 1e3;
  d.summary["calibration"]["rotation_error_arcsec"] = e.angle() * base::kArcsecPerRad;
}

void Align(Demo& d, const sim::VirtualProbe& vp, const json& truth) {
  d.out << "2. alignment: face A, holes B and C -> G54\n";
  const auto face = d.Capture(vp, "face_", {874, 668, 300, 200});
  const auto b = d.Capture(vp, "b_wall", {874, 668, 300, 200});
  const auto c = d.Capture(vp, "c_wall", {874, 668, 300, 200});
  const json r = d.Request(DemoPlateAlignRequest("demo-vmc", face, b, c));
  const Eigen::Vector3d origin = Vec(r.at("origin_mm"));
  d.out << std::fixed << std::setprecision(4) << "   G54 X" << origin.x() << " Y" << origin.y()
        << " Z" << origin.z() << " R" << r.at("rotation_z_deg").get<double>()
        << " deg: " << std::setprecision(2)
        << (origin - Vec(truth.at("work_origin_mcs_mm"))).norm() * 1e3 << " um and "
        << std::abs(r.at("rotation_z_deg").get<double>() -
                    truth.at("work_rotation_z_deg").get<double>()) *
               3600
        << " arcsec from the part's true placement\n";
  const Eigen::Vector3d error_um = (origin - Vec(truth.at("work_origin_mcs_mm"))) * 1e3;
  d.summary["alignment"] = {
      {"origin_error_um", {error_um.x(), error_um.y(), error_um.z()}},
      {"rotation_error_arcsec",
       (r.at("rotation_z_deg").get<double>() - truth.at("work_rotation_z_deg").get<double>()) *
           3600}};
}

void Measure(Demo& d, const sim::VirtualProbe& vp, const json& truth) {
  d.out << "3. the bore before its finishing pass (finished size 60.000 +0.030/-0)\n";
  const auto walls = d.Capture(vp, "bore_wall", {874, 668, 300, 200});
  const json& centre = truth.at("bore_centre_mcs_mm");
  const json r = d.Request(
      {{"op", "measure"},
       {"machine", "demo-vmc"},
       {"feature", "bore"},
       {"captures", walls},
       {"nominal",
        {{"top_centre_mm", centre}, {"diameter_mm", 60.0}, {"depth_mm", 20}, {"band_mm", 0.5}}},
       {"tolerance", {{"upper_mm", 0.03}, {"lower_mm", 0.0}}},
       {"update",
        {{"offset", kDemoTool},
         {"register", "radius_wear"},
         {"null_band_mm", 0.002},
         {"upper_limit_mm", 0.5}}}});
  d.out << std::fixed << std::setprecision(4) << "   diameter " << r.at("diameter_mm").get<double>()
        << " mm (true " << truth.at("bore_diameter_mm").get<double>() << "), "
        << r.at("verdict").get<std::string>()
        << " before finishing: " << r.at("reason").get<std::string>() << "\n";
  const json& u = r.at("update");
  d.out << "   tool " << kDemoTool << " radius " << u.at("before_mm").get<double>() << " -> "
        << u.at("after_mm").get<double>() << " mm (" << u.value("note", std::string()) << ")\n"
        << "   report: " << r.at("report").get<std::string>() << "\n";
  d.summary["bore"] = {
      {"diameter_mm", r.at("diameter_mm")},    {"true_diameter_mm", truth.at("bore_diameter_mm")},
      {"radius_before_mm", u.at("before_mm")}, {"radius_after_mm", u.at("after_mm")},
      {"change_mm", r.at("offset_change_mm")}, {"report", r.at("report")}};
}

}  // namespace

json SceneCaptureRequest(const std::string& machine,
                         const sim::VirtualProbe& probe,
                         const sim::Capture& capture,
                         const probe_fw::Aoi& aoi) {
  double first = 0, last = 0;
  probe.ColumnsReaching(capture, aoi, &first, &last);
  return {{"op", "capture"},
          {"machine", machine},
          {"capture_id", capture.id},
          {"mcs_from_flange", base::json_fields::PoseToJson(capture.mcs_from_flange)},
          {"aoi", {aoi.x0, aoi.y0, aoi.width, aoi.height}},
          {"columns", {first, last, 2.0}}};
}

json DemoPlateAlignRequest(const std::string& machine,
                           const std::vector<std::int64_t>& face,
                           const std::vector<std::int64_t>& hole_b,
                           const std::vector<std::int64_t>& hole_c) {
  const json o = {250, 120, -310};  // the setter's expectation: the plate within a millimetre
  return {{"op", "align"},
          {"machine", machine},
          {"method", "plane-circle-circle"},
          {"work_offset", 1},
          {"expected_origin_mm", o},
          {"plane_a", {{"captures", face}, {"nominal", {{"point_mm", o}, {"normal", {0, 0, 1}}}}}},
          {"circle_b",
           {{"captures", hole_b},
            {"nominal", {{"top_centre_mm", o}, {"diameter_mm", 20}, {"depth_mm", 20}}}}},
          {"circle_c",
           {{"captures", hole_c},
            {"nominal",
             {{"top_centre_mm", {250, 180, -310}}, {"diameter_mm", 20}, {"depth_mm", 20}}}}}};
}

namespace {

// --dir, --samples and --port into the demo (defaults: a fresh temporary folder, the samples
// beside the program, port 17420).
void DemoSettings(const Args& a, Demo* d) {
  d->dir = a.Text("--dir", "");
  d->samples = a.Text("--samples", "");
  d->port = static_cast<int>(a.Integer("--port", d->port, 1));
  if (d->port > 65535) throw UsageError("--port is 1..65535");
  if (d->samples.empty()) d->samples = DefaultSamplesDir();
  if (d->dir.empty())
    d->dir = fs::temp_directory_path() / ("mlprobe-demo-" + std::to_string(getpid()));
  d->dir = fs::absolute(d->dir);
  d->socket = (d->dir / "run" / "jobs.sock").string();
}

// The true mount M in the calibrated model's probe frame: the window alone moves that frame
// 0.68 mm from the true camera's (PROBE.md); the hand-eye is judged against it.
geometry::Pose3 TrueMount(const sim::VirtualProbe& vp, const fs::path& as_built, Demo* d) {
  double frame_rms_mm = 0.0;
  geometry::Pose3 true_m = vp.scene().flange_from_probe *
                           sim::TrueFromModelFrame(sim::LoadAsBuilt(as_built.string()), vp.model(),
                                                   &kSphereAoi, &frame_rms_mm);
  d->summary["calibration"]["frame_rms_um"] = frame_rms_mm * 1e3;
  return true_m;
}

// Steps 4 and 5: what was written for the controller, and where the time went.
void PrintDemoEnd(const Demo& d, std::ostream& out) {
  std::ifstream sub(d.dir / "subs" / "mlp_result.ngc");
  out << "4. written: " << (d.dir / "tool.tbl").string() << " (tool " << kDemoTool
      << "), the result subroutine the NC program calls:\n"
      << std::string(std::istreambuf_iterator<char>(sub), {}) << "   history: mlp history --db "
      << (d.dir / "data" / "history.sqlite").string() << "\n";
  const json& t = d.time_ms;
  out << std::setprecision(2) << "5. time: " << t.at("captures").get<int>() << " captures: frames "
      << t.at("frames").get<double>() / 1e3 << " s (the virtual probe renders them), firmware "
      << t.at("firmware").get<double>() / 1e3 << " s, link " << t.at("link").get<double>() / 1e3
      << " s, host " << t.at("capture_host").get<double>() / 1e3 << " s; the host's jobs "
      << t.at("jobs_host").get<double>() / 1e3 << " s\n";
}

}  // namespace

int RunDemoCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    std::ostringstream quiet;  // --json: the steps' text goes nowhere, the summary to out
    const Args a(args, {{"--dir", "--samples", "--port"}, {"--json"}});
    const bool as_json = a.Has("--json");
    Demo d{{}, {}, 17420, {}, as_json ? static_cast<std::ostream&>(quiet) : out};
    DemoSettings(a, &d);
    const fs::path scene = d.samples / "scenes" / "demo_plate.json";
    // The virtual probe renders as built (its optics off the design, a mirror's cubic, a sheet's
    // smile, a window); the firmware and the host know it only through its calibration, made
    // by `mlp calibrate projector` from chessboard views of that probe (docs/PROBE.md).
    const fs::path as_built = d.samples / "probes" / "as_built" / "MLP-AB-0001.json";
    const fs::path calibrated = d.samples / "probes" / "as_built" / "MLP-AB-0001.calibrated.json";
    WriteSite(d);
    d.out << "mlp demo: the virtual machine in " << d.dir.string() << "\n";
    Child hostd(
        {(ProgramDir() / "mlp-hostd").string(), "--config", (d.dir / "hostd.json").string()},
        d.dir / "hostd.log");
    WaitFor([&] { return fs::exists(d.socket); }, "mlp-hostd did not start: see hostd.log");
    Child sim({(ProgramDir() / "mlp-sim").string(), "serve", "--probe", as_built.string(),
               "--firmware-model", calibrated.string(), "--scene", scene.string(), "--port",
               std::to_string(d.port), "--key", (d.dir / "probe.key").string()},
              d.dir / "probe.log");
    WaitFor(
        [&] {
          const json s = service::SendRequest(d.socket, {{"op", "status"}}, 2000);
          return s.at("probes").at(0).at("connected").get<bool>();
        },
        "the virtual probe did not connect: see probe.log");
    d.out << "   mlp-hostd up, virtual probe MLP-REF-0001 connected (rendering as built, the "
             "firmware with its calibration cal-as-built-1)\n";
    // The host plans captures with what it knows: the calibrated model, not the as-built truth.
    const sim::VirtualProbe vp(probe_fw::LoadProbeModel(calibrated.string()),
                               sim::LoadScene(scene.string()));
    std::ifstream scene_file(scene);
    const json truth = json::parse(scene_file).at("truth");
    Calibrate(d, vp, TrueMount(vp, as_built, &d));
    Align(d, vp, truth);
    Measure(d, vp, truth);
    d.summary["tool_table"] = (d.dir / "tool.tbl").string();
    d.summary["subroutine"] = (d.dir / "subs" / "mlp_result.ngc").string();
    d.summary["time_ms"] = d.time_ms;
    if (as_json)
      out << d.summary.dump(2) << "\n";
    else
      PrintDemoEnd(d, out);
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp demo: " << e.what() << "\n" << kUsage;
    return kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp demo: " << e.what() << "\n";
    return 7;
  }
}

}  // namespace mlp::host
