#include "mlp/service/hostd.h"

#include "mlp/history/file_hash.h"
#include "mlp/history/history.h"
#include "mlp/link/transport.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/json_fields.h"
#include "mlp/service/capture_broker.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>

#include "job_common.h"

namespace mlp::service {
namespace {

namespace fs = std::filesystem;
namespace jf = probe_fw::json_fields;
using json = nlohmann::json;

class RequestError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::array<double, 16> RowMajor(const geometry::Pose3& p) {
  std::array<double, 16> m{};
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[static_cast<size_t>(4 * r + c)] = p.matrix()(r, c);
  return m;
}

// A capture request from the job's JSON: pose H, ROI, AOI and sweep (docs/HOSTD.md).
link::CaptureRequest ParseCapture(const json& j, const std::string& capture_id) {
  link::CaptureRequest r;
  r.capture_id = capture_id;
  r.mcs_from_flange = RowMajor(jf::Pose<RequestError>(
      jf::Object<RequestError>(j, "mcs_from_flange", "request"), "request.mcs_from_flange"));
  r.roi = j.contains("roi") ? jf::Text<RequestError>(j, "roi", "request") : "full";
  if (!j.contains("aoi") || !j.at("aoi").is_array() || j.at("aoi").size() != 4)
    throw RequestError("request.aoi must be [x0, y0, width, height] in sensor pixels");
  std::uint16_t* aoi[4] = {&r.aoi_x0, &r.aoi_y0, &r.aoi_width, &r.aoi_height};
  for (int k = 0; k < 4; ++k) {
    const json& v = j.at("aoi")[static_cast<size_t>(k)];
    if (!v.is_number_integer() || v.get<int>() < 0 || v.get<int>() > 65535)
      throw RequestError("request.aoi must hold whole numbers 0..65535");
    *aoi[k] = static_cast<std::uint16_t>(v.get<int>());
  }
  if (!j.contains("columns") || !j.at("columns").is_array() || j.at("columns").size() != 3)
    throw RequestError("request.columns must be [first, last, step] projector columns");
  for (const auto& v : j.at("columns"))
    if (!v.is_number()) throw RequestError("request.columns must hold numbers");
  r.first_column = j.at("columns")[0].get<double>();
  r.last_column = j.at("columns")[1].get<double>();
  r.column_step = j.at("columns")[2].get<double>();
  r.exposure_us = jf::NumberOr<RequestError>(j, "exposure_us", r.exposure_us, "request");
  return r;
}

}  // namespace

struct Hostd::Impl {
  HostdConfig config;
  Log log;
  history::History history;
  std::unique_ptr<CaptureBroker> broker;
  JobServer server;
  Clock::time_point started = Clock::now();
  std::map<std::string, std::unique_ptr<std::timed_mutex>> machine_locks;
  std::mutex busy_m;
  std::map<std::string, std::string> busy;  // machine -> what it runs

  Impl(HostdConfig c, Log l)
      : config(std::move(c)),
        log(std::move(l)),
        history((fs::create_directories(config.data_dir), config.HistoryFile())),
        server(config.job_socket, log) {
    link::HostLinkConfig link_config;
    link_config.bind_address = config.link_address;
    link_config.port = config.link_port;
    for (const ProbeEntry& p : config.probes) {
      try {
        link_config.probes[p.serial] = link::LoadKeyFile(p.key_file);
      } catch (const link::LinkError& e) {
        throw ConfigError(config.path + ": probe " + p.serial + ": " + e.what());
      }
    }
    broker = std::make_unique<CaptureBroker>(link_config, log);
    for (const MachineConfig& m : config.machines)
      machine_locks[m.name] = std::make_unique<std::timed_mutex>();
    for (auto id : history.CloseInterruptedJobs("the host stopped while the job ran"))
      log("history: job " + std::to_string(id) + " was left running by the last run: failed");
    server.Handle("status", [this](const json&) { return Status(); });
    server.Handle("capture", [this](const json& r) {
      return RunOnMachine(
          r, [this](const MachineConfig& m, const json& req) { return Capture(m, req); });
    });
    // Jobs on stored captures: the same context, one machine at a time.
    const std::pair<const char*, json (*)(JobContext&, const json&)> jobs[] = {
        {"plan", &RunPlanJob},
        {"measure", &RunMeasureJob},
        {"align", &RunAlignJob},
        {"calibrate", &RunCalibrateJob},
        {"recheck", &RunRecheckJob}};
    for (const auto& [op, run] : jobs) {
      server.Handle(op, [this, run = run](const json& r) {
        return RunOnMachine(r, [&](const MachineConfig& m, const json& req) {
          JobContext ctx{config, m, history, log};
          return run(ctx, req);
        });
      });
    }
  }

  json Status() {
    json probes = json::array();
    const auto connected = broker->ConnectedProbes();
    for (const ProbeEntry& p : config.probes) {
      json e = {{"serial", p.serial},
                {"connected",
                 std::find(connected.begin(), connected.end(), p.serial) != connected.end()}};
      if (const auto s = broker->LatestStatus(p.serial)) {
        e["battery_percent"] = s->battery_percent;
        e["temperature_c"] = s->temperature_c;
        e["buffer_used"] = s->buffer_used;
        e["buffer_capacity"] = s->buffer_capacity;
      }
      probes.push_back(e);
    }
    json machines = json::array();
    {
      std::lock_guard lock(busy_m);
      for (const MachineConfig& m : config.machines) {
        const auto it = busy.find(m.name);
        machines.push_back({{"name", m.name},
                            {"probe", m.probe_serial},
                            {"running", it == busy.end() ? "" : it->second}});
      }
    }
    return {{"ok", true},
            {"uptime_s", Ms(started) / 1000.0},
            {"probe_link_port", broker->Port()},
            {"probes", probes},
            {"machines", machines},
            {"history", config.HistoryFile()}};
  }

  using Job = std::function<json(const MachineConfig&, const json&)>;

  // One job per machine: wait for the machine up to its job timeout, then refuse as busy.
  json RunOnMachine(const json& request, Job job) {
    const std::string name = jf::Text<RequestError>(request, "machine", "request");
    const MachineConfig* m = config.Machine(name);
    if (m == nullptr) throw RequestError("no machine \"" + name + "\" in " + config.path);
    std::timed_mutex& lock = *machine_locks.at(name);
    if (!lock.try_lock_for(std::chrono::duration<double>(m->job_timeout_s)))
      return {{"ok", false},
              {"status", "failed"},
              {"error", "machine " + name + " is busy with another job"}};
    std::lock_guard held(lock, std::adopt_lock);
    {
      std::lock_guard b(busy_m);
      busy[name] = request.at("op").get<std::string>();
    }
    struct Idle {
      Impl& s;
      std::string name;
      ~Idle() {
        std::lock_guard b(s.busy_m);
        s.busy.erase(name);
      }
    } idle{*this, name};
    return job(*m, request);
  }

  // Where a capture's time went: the probe's frames and firmware (durations on its own clock),
  // the link (the rest of the host's round trip: the request out, the cloud back), the host
  // (store and hash). The virtual probe's "frames" are its rendering.
  static json CaptureTimings(const link::LinkCloud& c, double round_trip_ms, double total_ms) {
    const double frames_ms = static_cast<double>(c.last_frame_ns - c.first_frame_ns) * 1e-6;
    const double firmware_ms = static_cast<double>(c.processed_ns - c.last_frame_ns) * 1e-6;
    return {{"frames", frames_ms},
            {"firmware", firmware_ms},
            {"link", std::max(0.0, round_trip_ms - frames_ms - firmware_ms)},
            {"host", total_ms - round_trip_ms},
            {"total", total_ms}};
  }

  json Capture(const MachineConfig& m, const json& request) {
    const auto t0 = Clock::now();
    const std::int64_t job = history.StartJob({m.name, "capture", m.probe_serial, "", request});
    try {
      const std::string name = request.contains("capture_id")
                                   ? jf::Text<RequestError>(request, "capture_id", "request")
                                   : std::string("c1");
      const std::string id = m.name + "-" + std::to_string(job) + "-" + name;
      const link::CaptureRequest cr = ParseCapture(request, id);
      const auto sent = Clock::now();
      const link::LinkCloud cloud = broker->Capture(
          m.probe_serial, cr,
          std::chrono::milliseconds(static_cast<long>(config.capture_timeout_s * 1000)));
      const double round_trip_ms = Ms(sent);
      const fs::path dir = fs::path(config.CloudDir()) / std::to_string(job);
      fs::create_directories(dir);
      const std::string path = (dir / (name + ".ply")).string();
      probe_fw::WriteCloudPly(
          path, cloud.xyz, cloud.quality,
          {cloud.probe_serial, cloud.calibration_id, cloud.capture_id, cloud.mcs_from_flange});
      const std::string sha = history::Sha256OfFile(path);
      json pose = request.at("mcs_from_flange");
      history.AddCapture(job, {id, pose, path, sha, static_cast<std::int64_t>(cloud.size())});
      const json timings = CaptureTimings(cloud, round_trip_ms, Ms(t0));
      const json reply = {{"ok", true},
                          {"status", "done"},
                          {"job_id", job},
                          {"capture_id", id},
                          {"points", cloud.size()},
                          {"cloud_path", path},
                          {"cloud_sha256", sha},
                          {"probe_calibration_id", cloud.calibration_id},
                          {"timings_ms", timings}};
      history.FinishJob(job, history::JobStatus::kDone, reply, timings);
      return reply;
    } catch (const std::exception& e) {
      const json reply = {
          {"ok", false}, {"status", "failed"}, {"job_id", job}, {"error", e.what()}};
      history.FinishJob(job, history::JobStatus::kFailed, reply, {{"total", Ms(t0)}});
      log("job " + std::to_string(job) + " (capture on " + m.name + ") failed: " + e.what());
      return reply;
    }
  }
};

Hostd::Hostd(HostdConfig config, Log log)
    : impl_(std::make_unique<Impl>(std::move(config), std::move(log))) {}

Hostd::~Hostd() { Stop(); }

void Hostd::Start() {
  impl_->broker->Start();
  impl_->server.Start();
  impl_->log("mlp-hostd: probe link on " + impl_->config.link_address + ":" +
             std::to_string(impl_->broker->Port()) + ", jobs on " + impl_->config.job_socket);
}

void Hostd::Stop() {
  impl_->server.Stop();
  impl_->broker->Stop();
}

std::uint16_t Hostd::LinkPort() const { return impl_->broker->Port(); }

}  // namespace mlp::service
