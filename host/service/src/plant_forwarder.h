#pragma once
// Every finished job to the plant's database (internal to mlp_service): the history queues each
// job as it is closed (its outbox, in the same transaction), and this thread sends the queue in
// order, each job in one transaction of the plant's database, removing it from the outbox only
// once it is there. A database that is away is retried (1 s, doubling to 30 s); nothing is lost,
// over a restart of the host too. Without `plant_database` in the configuration nothing runs.

#include "mlp/service/config.h"
#include "mlp/service/job_server.h"

#include <memory>

#include <nlohmann/json.hpp>

namespace mlp::service {

class PlantForwarder {
 public:
  PlantForwarder(const HostdConfig& config, Log log);
  ~PlantForwarder();
  PlantForwarder(const PlantForwarder&) = delete;
  PlantForwarder& operator=(const PlantForwarder&) = delete;

  /// Opens the outbox (queuing every job already closed the first time) and starts sending.
  void Start();
  /// Sends what is queued, then stops (waits up to the current send's end).
  void Stop();
  /// A job was closed: send soon rather than at the next poll.
  void Wake();
  /// {"connected", "waiting", "sent", "last_error"} for the status op; null when off.
  nlohmann::json Counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::service
