#include "plant_forwarder.h"

#include "mlp/history/history.h"
#include "mlp/plant/database.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <thread>

namespace mlp::service {

using json = nlohmann::json;

struct PlantForwarder::Impl {
  std::string host_id;
  Log log;
  // Its own connection to the history file (WAL: the jobs' connection is never blocked long).
  std::unique_ptr<history::History> history;
  std::unique_ptr<plant::PlantDatabase> db;
  std::thread thread;
  mutable std::mutex m;
  std::condition_variable wake;
  bool stop = false, woken = false, connected = false, said_down = false, finished = false;
  std::int64_t sent = 0, waiting = -1;  // waiting: as last counted by this thread
  std::string last_error;
  std::set<std::int64_t> unreadable;  // jobs the history cannot export: left queued, skipped

  // Sends the outbox in order; true when it is empty (or holds only unreadable jobs).
  bool SendQueued() {
    constexpr int kBatch = 50;
    for (;;) {
      const std::int64_t queued = history->PlantOutboxSize();
      {
        std::lock_guard lock(m);
        waiting = queued;
      }
      std::vector<history::History::OutboxEntry> batch = history->PlantOutbox(kBatch);
      std::erase_if(batch, [&](const auto& e) { return unreadable.count(e.job) > 0; });
      if (batch.empty()) return true;
      for (const auto& entry : batch) {
        {
          std::lock_guard lock(m);
          if (stop) return false;
        }
        json job;
        try {
          job = history->ExportJob(entry.job);
        } catch (const history::HistoryError& e) {
          unreadable.insert(entry.job);
          log("plant database: job " + std::to_string(entry.job) +
              " cannot be read from the history, left queued: " + e.what());
          continue;
        }
        db->Send(host_id, job);  // throws PlantDatabaseError: retried later
        history->PlantSent(entry);
        std::lock_guard lock(m);
        ++sent, --waiting;
      }
    }
  }

  void Run() {
    std::chrono::seconds retry(1);
    constexpr std::chrono::seconds kPoll(2), kMaxRetry(30);
    for (;;) {
      bool ok = false;
      try {
        SendQueued();
        ok = true;
      } catch (const std::exception& e) {  // the database away, or the history busy
        std::unique_lock lock(m);
        connected = false;
        last_error = e.what();
        const bool say = !said_down;
        said_down = true;
        lock.unlock();
        if (say) log(std::string("plant database: ") + e.what() + "; jobs wait in the outbox");
      }
      std::unique_lock lock(m);
      if (ok) {
        if (said_down) log("plant database: reached again; the outbox is sent");
        connected = true, said_down = false, last_error.clear();
        retry = std::chrono::seconds(1);
      }
      if (stop) return;
      const auto wait = ok ? std::chrono::duration_cast<std::chrono::seconds>(kPoll) : retry;
      if (!ok) retry = std::min(retry * 2, kMaxRetry);
      wake.wait_for(lock, wait, [this] { return stop || woken; });
      woken = false;
      if (stop) {
        // What the last jobs closed, if the database answered the last time: a server that is
        // away would hold the stop up for its connect timeout.
        const bool reachable = connected;
        lock.unlock();
        try {
          if (reachable) SendQueued();
        } catch (const std::exception&) {
          // kept in the outbox for the next start
        }
        return;
      }
    }
  }
};

PlantForwarder::PlantForwarder(const HostdConfig& config, Log log) {
  if (!config.plant_database) return;
  impl_ = std::make_unique<Impl>();
  impl_->host_id = config.host_id;
  impl_->log = std::move(log);
  impl_->history = std::make_unique<history::History>(config.HistoryFile());
  impl_->db = std::make_unique<plant::PlantDatabase>(config.plant_database->connection);
}

PlantForwarder::~PlantForwarder() { Stop(); }

void PlantForwarder::Start() {
  if (!impl_ || impl_->thread.joinable()) return;
  impl_->history->EnablePlantOutbox();
  impl_->thread = std::thread([this] {
    impl_->Run();
    std::lock_guard lock(impl_->m);
    impl_->finished = true;
    impl_->wake.notify_all();
  });
}

void PlantForwarder::Stop() {
  if (!impl_) return;
  if (!impl_->thread.joinable()) return;
  std::unique_lock lock(impl_->m);
  impl_->stop = true;
  impl_->wake.notify_all();
  // A send in progress may finish; one that waits on a stalled server (a locked table, a
  // server that went silent) is cut: the job stays in the outbox. Before, a SIGTERM waited 39 s
  // on a locked table and for ever on a silent server.
  constexpr std::chrono::milliseconds kGrace(1000), kRetry(100);
  if (!impl_->wake.wait_for(lock, kGrace, [this] { return impl_->finished; })) {
    while (!impl_->wake.wait_for(lock, kRetry, [this] { return impl_->finished; })) {
      lock.unlock();
      impl_->db->Interrupt();  // again: it may have been connecting (bounded at 5 s)
      lock.lock();
    }
  }
  lock.unlock();
  impl_->thread.join();
}

void PlantForwarder::Wake() {
  if (!impl_) return;
  {
    std::lock_guard lock(impl_->m);
    impl_->woken = true;
  }
  impl_->wake.notify_all();
}

json PlantForwarder::Counters() const {
  if (!impl_) return nullptr;
  std::lock_guard lock(impl_->m);
  return {{"connected", impl_->connected},
          {"waiting", impl_->waiting},
          {"sent", impl_->sent},
          {"last_error", impl_->last_error}};
}

}  // namespace mlp::service
