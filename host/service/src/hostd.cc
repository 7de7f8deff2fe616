#include "mlp/service/hostd.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/history/file_hash.h"
#include "mlp/history/history.h"
#include "mlp/link/transport.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/service/adapters.h"
#include "mlp/service/capture_broker.h"
#include "mlp/service/request_json.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <thread>

#include "job_common.h"
#include "plant_feed.h"
#include "plant_forwarder.h"

namespace mlp::service {
namespace {

namespace fs = std::filesystem;
namespace jf = base::json_fields;
using json = nlohmann::json;

class RequestError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The first job number that no file of the data folder uses yet: clouds/<N>/ and
// reports/<machine>-job<N>.svg of an earlier history must never be written over.
std::int64_t NextFreeJobNumber(const HostdConfig& c) {
  std::int64_t highest = 0;
  const auto number = [](const std::string& digits) -> std::int64_t {
    if (digits.empty() || digits.size() > 15 ||
        digits.find_first_not_of("0123456789") != std::string::npos)
      return 0;
    return std::stoll(digits);
  };
  std::error_code ec;
  for (fs::directory_iterator it(c.CloudDir(), ec), end; !ec && it != end; it.increment(ec))
    highest = std::max(highest, number(it->path().filename().string()));
  ec.clear();
  std::vector<std::string> named = {c.ReportDir()};  // <machine>-job<N>.svg / .json / .nc
  for (const MachineConfig& m : c.machines) named.push_back(m.controller.result_dir);
  for (const std::string& dir : named) {
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
      const std::string stem = it->path().stem().string();
      const auto at = stem.rfind("-job");
      if (at != std::string::npos) highest = std::max(highest, number(stem.substr(at + 4)));
    }
    ec.clear();
  }
  return highest + 1;
}

// A capture request from the job's JSON: pose H, ROI, AOI and sweep (docs/HOSTD.md).
link::CaptureRequest ParseCapture(const json& j, const std::string& capture_id) {
  link::CaptureRequest r;
  r.capture_id = capture_id;
  r.mcs_from_flange = jf::Pose<RequestError>(
      jf::Object<RequestError>(j, "mcs_from_flange", "request"), "request.mcs_from_flange");
  r.roi = j.contains("roi") ? jf::Text<RequestError>(j, "roi", "request") : "full";
  if (!j.contains("aoi") || !j.at("aoi").is_array() || j.at("aoi").size() != 4)
    throw RequestError("request.aoi must be [x0, y0, width, height] in sensor pixels");
  std::uint16_t* aoi[4] = {&r.aoi_x0, &r.aoi_y0, &r.aoi_width, &r.aoi_height};
  for (int k = 0; k < 4; ++k) {
    const json& v = j.at("aoi")[static_cast<size_t>(k)];
    // Compared as 64 bits: 2^32 + 874 is out of range, not 874.
    if (!v.is_number_integer() || v.get<std::int64_t>() < 0 || v.get<std::int64_t>() > 65535 ||
        (v.is_number_unsigned() && v.get<std::uint64_t>() > 65535))
      throw RequestError("request.aoi must hold whole numbers 0..65535");
    *aoi[k] = static_cast<std::uint16_t>(v.get<std::int64_t>());
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
  std::atomic<bool> history_lost{false};
  PlantFeed feed;
  PlantForwarder forwarder;
  // The retained status on the plant's broker, refreshed every mqtt.status_period_s.
  std::thread status_thread;
  std::mutex status_m;
  std::condition_variable status_wake;
  bool status_stop = false;

  Impl(HostdConfig c, Log l)
      : config(std::move(c)),
        log(std::move(l)),
        history((fs::create_directories(config.data_dir), config.HistoryFile())),
        server(config.job_socket, log),
        feed(config, log),
        forwarder(config, log) {
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
    history.SetJobIdFloor(NextFreeJobNumber(config));
    RemoveTemporaries();
    SettleInterruptedWrites();
    for (auto id : history.CloseInterruptedJobs("the host stopped while the job ran"))
      log("history: job " + std::to_string(id) + " was left running by the last run: failed");
    server.Handle("status", [this](const json&) { return Status(); });
    for (const MachineConfig& m : config.machines) server.AddLane(m.name);
    server.HandleInLane("capture", [this](const json& r) {
      return RunOnMachine(
          r, [this](const MachineConfig& m, const json& req) { return Capture(m, req); });
    });
    server.HandleInLane("reject_capture", [this](const json& r) {
      return RunOnMachine(
          r, [this](const MachineConfig& m, const json& req) { return RejectCapture(m, req); });
    });
    // Jobs on stored captures: the same context, one machine at a time.
    const std::pair<const char*, json (*)(JobContext&, const json&)> jobs[] = {
        {"plan", &RunPlanJob},           {"measure", &RunMeasureJob},      {"align", &RunAlignJob},
        {"calibrate", &RunCalibrateJob}, {"recheck", &RunRecheckJob},      {"tool", &RunToolJob},
        {"relocate", &RunRelocateJob},   {"kinematics", &RunKinematicsJob}};
    for (const auto& [op, run] : jobs) {
      server.HandleInLane(op, [this, run = run](const json& r) {
        return RunOnMachine(r, [&](const MachineConfig& m, const json& req) {
          JobContext ctx{config, m, history, log, feed};
          return run(ctx, req);
        });
      });
    }
  }

  // Temporary files of writes a stop cut short (base::IsTemporaryName): never the real files,
  // which are renamed into place whole.
  void RemoveTemporaries() {
    std::vector<fs::path> dirs = {config.data_dir};
    for (const MachineConfig& m : config.machines) {
      dirs.push_back(m.controller.result_dir);
      if (!m.controller.tool_table.empty())
        dirs.push_back(fs::path(m.controller.tool_table).parent_path());
    }
    for (const fs::path& dir : dirs) {
      std::error_code ec;
      for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (!base::IsTemporaryName(name) || !it->is_regular_file()) continue;
        std::error_code rm;
        fs::remove(it->path(), rm);
        log("removed " + it->path().string() + ", left by a write that a stop cut short");
      }
    }
  }

  // A job killed between announcing its writes and confirming them: the controller's state
  // decides how it is recorded (docs/HOSTD.md, "Stops and repeats").
  void SettleInterruptedWrites() {
    for (const history::InterruptedWrite& w : history.InterruptedWrites()) {
      const MachineConfig* m = config.Machine(w.machine);
      // From the announced rows, not the reply's shape: a tool or relocate job's reply is not
      // a measure's, and reading only the latter sent those jobs to the .ngc header, which is
      // written before the table (1 kill in 40 recorded "written" a table never changed).
      // Confirmed writes are the controller's too: never "failed", never run again.
      const bool written =
          w.confirmed || (m != nullptr && WritesReachedController(m->controller, w.machine, w.job,
                                                                  ToolChangesOf(w.writes)));
      json reply = w.reply;
      history::JobStatus status = history::JobStatus::kFailed;
      if (written) {
        reply["ok"] = true;
        reply["note"] = w.confirmed ? "the host stopped after its write to the controller was "
                                      "confirmed, before the job was closed"
                                    : "the host stopped after writing to the controller; found "
                                      "written at the next start";
        status = history::JobStatusFrom(reply.value("status", "done"));
      } else {
        reply["ok"] = false;
        reply["status"] = "failed";
        reply["error"] =
            "the host stopped before its write reached the controller: nothing written";
      }
      history.SettleInterrupted(w.job, written, status, reply);
      log("history: job " + std::to_string(w.job) + " on " + w.machine +
          (w.confirmed ? " was stopped after its write to the controller: "
                       : " was stopped during its write to the controller: ") +
          (written ? "the write is there, recorded as " + history::ToString(status)
                   : std::string("the write is not there, recorded as failed")));
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
        e["charging"] = (s->flags & link::kStatusCharging) != 0;
        e["frames_dropped"] = s->frames_dropped;
        e["last_error"] =
            s->last_error == 0
                ? std::string()
                : std::string(link::ToString(static_cast<link::ProbeErrorCode>(s->last_error)));
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
            {"history", config.HistoryFile()},
            {"history_ok", HistoryOk()},
            {"mqtt", feed.Counters()},
            {"plant_database", forwarder.Counters()}};
  }

  void StartStatusFeed() {
    if (!feed.On()) return;
    status_thread = std::thread([this] {
      const auto period = std::chrono::duration<double>(config.mqtt->status_period_s);
      std::unique_lock lock(status_m);
      do {
        lock.unlock();
        feed.Status(Status());
        lock.lock();
      } while (!status_wake.wait_for(lock, period, [this] { return status_stop; }));
    });
  }

  void StopStatusFeed() {
    {
      std::lock_guard lock(status_m);
      status_stop = true;
    }
    status_wake.notify_all();
    if (status_thread.joinable()) status_thread.join();
  }

  // False (and logged once) when the history file was removed or replaced under the host.
  bool HistoryOk() {
    try {
      history.CheckFile();
      return true;
    } catch (const history::HistoryError& e) {
      if (!history_lost.exchange(true)) log(std::string("error: ") + e.what());
      return false;
    }
  }

  using Job = std::function<json(const MachineConfig&, const json&)>;

  // Every answer on a machine also goes to the plant's feed (a repeat's, which ran nothing,
  // does not).
  json RunOnMachine(const json& request, const Job& job) {
    const std::string name = jf::Text<RequestError>(request, "machine", "request");
    const MachineConfig* m = config.Machine(name);
    if (m == nullptr) throw RequestError("no machine \"" + name + "\" in " + config.path);
    const std::string op = request.value("op", "");
    json reply;
    try {
      reply = RunLocked(*m, request, job);
    } catch (const std::exception& e) {
      feed.Answered(name, op, {{"ok", false}, {"status", "failed"}, {"error", e.what()}});
      throw;
    }
    if (!reply.value("repeated", false)) feed.Answered(name, op, reply);
    forwarder.Wake();
    return reply;
  }

  // One job per machine: wait for the machine up to its job timeout, then refuse as busy.
  json RunLocked(const MachineConfig& machine, const json& request, const Job& job) {
    const MachineConfig* m = &machine;
    const std::string& name = machine.name;
    std::timed_mutex& lock = *machine_locks.at(name);
    if (!lock.try_lock_for(std::chrono::duration<double>(m->job_timeout_s)))
      return {{"ok", false},
              {"status", "failed"},
              {"error", "machine " + name + " is busy with another job"}};
    std::lock_guard held(lock, std::adopt_lock);
    if (!HistoryOk())
      return {{"ok", false},
              {"status", "failed"},
              {"error", "the history " + config.HistoryFile() +
                            " was removed or replaced while the host ran: no job runs until "
                            "mlp-hostd is restarted"}};
    if (auto earlier = Repeated(*m, request)) return *earlier;
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

  // A request whose request_id this machine has seen: the earlier job's reply when that job
  // succeeded or touched the controller (a retry after a lost reply must not compensate
  // twice); nothing, so that it runs again, when it failed or was refused before any write.
  std::optional<json> Repeated(const MachineConfig& m, const json& request) {
    const std::string id = RequestId(request);
    if (id.empty()) return std::nullopt;
    const auto earlier = history.FindRequest(m.name, id);
    if (!earlier) return std::nullopt;
    const bool succeeded = earlier->reply.value("ok", false);
    if (!earlier->wrote && !succeeded) return std::nullopt;
    // The same key with another body is a new request that a stale or copied request_id
    // would silently drop (an operator's new offset answered "repeated" and never written):
    // refused, so that the macro sees it and sends a fresh key.
    if (!RepeatsStoredRequest(request, earlier->request)) {
      log("request " + id + " on " + m.name + " refused: job " + std::to_string(earlier->job) +
          " ran another request with that request_id");
      return json{{"ok", false},
                  {"status", "refused"},
                  {"earlier_job", earlier->job},
                  {"error", "request_id \"" + id + "\" was used by job " +
                                std::to_string(earlier->job) + " for another request on " + m.name +
                                ": nothing run; give this request a request_id of its own"}};
    }
    json reply = earlier->reply;
    reply["repeated"] = true;
    reply["earlier_job"] = earlier->job;
    log("request " + id + " on " + m.name + " was carried out by job " +
        std::to_string(earlier->job) + ": answered with its reply, nothing run again");
    return reply;
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

  static json StripesJson(const link::StripeAccount& a) {
    return {{"kept", a.kept},
            {"rejected_share", a.RejectedShare()},
            {"rejected",
             {{"saturated", a.saturated},
              {"double_peak", a.double_peak},
              {"too_wide", a.too_wide},
              {"too_narrow", a.too_narrow},
              {"indirect", a.indirect},
              {"second_on_epipolar_line", a.second_on_line},
              {"undecided_on_epipolar_line", a.undecided_on_line},
              {"beside_rejected_stripe", a.beside_rejected},
              {"reflectance_slope", a.reflectance},
              {"isolated", a.isolated}}},
            {"not_stripe_light", {{"weak", a.weak}, {"cut", a.cut}}}};
  }

  std::string RejectedStripesError(const link::StripeAccount& a) const {
    char share[96];
    std::snprintf(share, sizeof share, "%.0f %% of the stripe's light (limit %.0f %%)",
                  100.0 * a.RejectedShare(), 100.0 * config.max_rejected_stripe_share);
    return std::string("the firmware rejected ") + share +
           " as reflections, saturation or broken profiles: no offset is taken from this "
           "capture (its counts under \"stripes\"; max_rejected_stripe_share in the config)";
  }

  // The macro saw the machine move while a capture's frames were taken (its pose after the
  // frames differs from the pose it sent): that capture must never be used.
  json RejectCapture(const MachineConfig& m, const json& request) {
    const std::int64_t job = jf::Integer<RequestError>(request, "job_id", "request");
    std::string reason = jf::Text<RequestError>(request, "reason", "request");
    constexpr std::size_t kMaxReason = 300;
    if (reason.size() > kMaxReason) reason.resize(kMaxReason);
    if (!history.RejectCapture(m.name, job, "rejected by the controller: " + reason))
      throw RequestError("job " + std::to_string(job) + " is no finished capture on " + m.name);
    log("capture job " + std::to_string(job) + " on " + m.name +
        " rejected by the controller: " + DumpSafe(json(reason)));
    return {{"ok", true}, {"status", "done"}, {"job_id", job}, {"rejected", true}};
  }

  // The capture's cloud as data/clouds/<job>/<name>.ply; never over an existing file.
  std::string StoreCloud(std::int64_t job, const std::string& name, const link::LinkCloud& cloud) {
    const fs::path dir = fs::path(config.CloudDir()) / std::to_string(job);
    fs::create_directories(dir);
    std::string path = (dir / (name + ".ply")).string();
    if (fs::exists(path))  // the history and the data folder disagree: keep the older file
      throw history::HistoryError("the cloud file " + path +
                                  " exists already (a history that restarted its job numbers?): "
                                  "not written over");
    probe_fw::WriteCloudPly(path, cloud.xyz, cloud.quality,
                            {cloud.probe_serial, cloud.calibration_id, cloud.capture_id,
                             cloud.mcs_from_flange, "probe", cloud.edge});
    return path;
  }

  json Capture(const MachineConfig& m, const json& request) {
    const auto t0 = Clock::now();
    const std::string name = request.contains("capture_id")
                                 ? jf::Text<RequestError>(request, "capture_id", "request")
                                 : std::string("c1");
    CheckSafeName(name, "request.capture_id");
    const std::int64_t job = history.StartJob(
        {m.name, "capture", m.probe_serial, "", StoredRequest(request), RequestId(request)});
    try {
      const std::string id = m.name + "-" + std::to_string(job) + "-" + name;
      const link::CaptureRequest cr = ParseCapture(request, id);
      const auto sent = Clock::now();
      const link::LinkCloud cloud = broker->Capture(
          m.probe_serial, cr,
          std::chrono::milliseconds(static_cast<long>(config.capture_timeout_s * 1000)));
      const double round_trip_ms = Ms(sent);
      const std::string path = StoreCloud(job, name, cloud);
      const std::string sha = history::Sha256OfFile(path);
      const json& pose = request.at("mcs_from_flange");
      history.AddCapture(job, {id, pose, path, sha, static_cast<std::int64_t>(cloud.size())});
      const json timings = CaptureTimings(cloud, round_trip_ms, Ms(t0));
      json reply = {{"ok", true},
                    {"status", "done"},
                    {"job_id", job},
                    {"capture_id", id},
                    {"points", cloud.size()},
                    {"cloud_path", path},
                    {"cloud_sha256", sha},
                    {"probe_calibration_id", cloud.calibration_id},
                    {"timings_ms", timings}};
      if (cloud.edge)
        reply["edge"] = {{"points", cloud.edge->points}, {"rms_px", cloud.edge->rms_px}};
      reply["stripes"] = StripesJson(cloud.stripes);
      if (cloud.stripes.RejectedShare() > config.max_rejected_stripe_share) {
        reply["ok"] = false, reply["status"] = "refused";
        reply["error"] = RejectedStripesError(cloud.stripes);
        log("job " + std::to_string(job) + " (capture on " + m.name +
            ") refused: " + reply["error"].get<std::string>());
        history.FinishJob(job, history::JobStatus::kRefused, reply, timings);
        return reply;
      }
      history.FinishJob(job, history::JobStatus::kDone, reply, timings);  // throws: failed
      return reply;
    } catch (const std::exception& e) {
      json reply = {{"ok", false}, {"status", "failed"}, {"job_id", job}, {"error", e.what()}};
      log("job " + std::to_string(job) + " (capture on " + m.name + ") failed: " + e.what());
      try {
        history.FinishJob(job, history::JobStatus::kFailed, reply, {{"total", Ms(t0)}});
      } catch (const std::exception& h) {
        reply["history_error"] = h.what();
        log("job " + std::to_string(job) + " is not recorded as failed: " + h.what());
      }
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
  impl_->StartStatusFeed();
  impl_->forwarder.Start();
  impl_->log("mlp-hostd: probe link on " + impl_->config.link_address + ":" +
             std::to_string(impl_->broker->Port()) + ", jobs on " + impl_->config.job_socket);
}

void Hostd::Stop() {
  impl_->broker->FailWaiting();
  impl_->server.Stop();
  impl_->broker->Stop();
  impl_->StopStatusFeed();
  impl_->forwarder.Stop();
}

std::uint16_t Hostd::LinkPort() const { return impl_->broker->Port(); }

}  // namespace mlp::service
