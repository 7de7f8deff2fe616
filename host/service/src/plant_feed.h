#pragma once
// The host's live feed to the plant (internal to mlp_service): every job's end, offset write and
// refusal, and the host's and probes' status, as JSON on MQTT (docs/HOSTD.md, "Plant"). Without
// an `mqtt` section in the configuration every call does nothing.

#include "mlp/history/history.h"
#include "mlp/service/config.h"
#include "mlp/service/job_server.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::plant {
class MqttPublisher;
}

namespace mlp::service {

class PlantFeed {
 public:
  /// Reads the password file (owner-only, like the probes' keys); throws ConfigError. Starts
  /// connecting in the background: a broker that is away never stops the host.
  PlantFeed(const HostdConfig& config, Log log);
  /// Says "offline" (retained) and disconnects cleanly.
  ~PlantFeed();
  PlantFeed(const PlantFeed&) = delete;
  PlantFeed& operator=(const PlantFeed&) = delete;

  bool On() const { return publisher_ != nullptr; }
  /// A request on `machine` answered: its reply on .../result, and on .../refusal as well when
  /// it was refused (a refused job, a busy machine, a request that could not be read).
  void Answered(const std::string& machine, const std::string& op, const nlohmann::json& reply);
  /// Writes a job made to the controller, once confirmed, on .../offset.
  void OffsetsWritten(const std::string& machine,
                      std::int64_t job,
                      const std::vector<history::OffsetWriteRow>& rows);
  /// The host's status (the `status` op's reply), retained, and each probe's, retained.
  void Status(const nlohmann::json& host_status);
  /// The client's counters for the `status` op; null when off.
  nlohmann::json Counters() const;

 private:
  std::string Topic(const std::string& tail) const;
  nlohmann::json Stamp(nlohmann::json payload) const;

  std::string host_id_, prefix_;
  std::unique_ptr<plant::MqttPublisher> publisher_;
};

}  // namespace mlp::service
