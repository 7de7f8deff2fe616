#pragma once
/// @file A host's live feed to the plant over MQTT (OASIS MQTT 3.1.1): JSON messages with QoS 1
/// (at least once), a retained status, and a last will that the broker publishes when the host
/// goes away without saying so. TLS and user/password from the configuration. The broker being
/// away never stops a job: messages wait in memory (bounded) and go out when it is back.

#include "mlp/base/input_error.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

namespace mlp::plant {

/// A configuration the client cannot use (names the field), or a topic MQTT does not allow.
class MqttError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct MqttTls {
  std::string ca_file;    ///< the broker's certificate is checked against it; "" = no TLS
  std::string cert_file;  ///< a client certificate, with key_file, when the broker asks for one
  std::string key_file;
};

struct MqttOptions {
  std::string host = "127.0.0.1";
  int port = 1883;
  std::string client_id;  ///< unique per broker: a second client with the same id throws it off
  std::string username, password;  ///< "" = anonymous
  MqttTls tls;
  int keepalive_s = 30;  ///< the broker declares the host gone after 1.5 x this without a word
  /// Messages published and not yet acknowledged by the broker (QoS 1), kept while it is away;
  /// beyond this, new messages are dropped and counted (a host must not grow without bound).
  int max_queued = 10000;
  /// Published, retained, by the broker when the connection drops without a DISCONNECT.
  std::string will_topic;
  nlohmann::json will_payload;
};

struct MqttCounters {
  bool connected = false;
  std::string last_error;      ///< the broker's or the socket's last word, "" when none
  std::int64_t published = 0;  ///< acknowledged by the broker
  std::int64_t queued = 0;     ///< handed over, not yet acknowledged
  std::int64_t dropped = 0;    ///< refused because the queue was full
};

using MqttLog = std::function<void(const std::string& line)>;

/// One connection to one broker, with its own network thread; thread-safe.
class MqttPublisher {
 public:
  /// Starts connecting in the background (a broker that is not up yet is retried every 1 to
  /// 30 s). Throws MqttError for options it cannot use (a missing CA file, an empty client id).
  MqttPublisher(MqttOptions options, MqttLog log);
  /// Disconnects cleanly after waiting up to 2 s for queued messages (no last will then).
  ~MqttPublisher();
  MqttPublisher(const MqttPublisher&) = delete;
  MqttPublisher& operator=(const MqttPublisher&) = delete;

  /// Queues `payload` as JSON on `topic`, QoS 1. False (and counted) when the queue is full or
  /// the client refuses it; never throws for a broker that is away.
  bool Publish(const std::string& topic, const nlohmann::json& payload, bool retain = false);
  /// Waits until every queued message is acknowledged, up to `timeout`; true when none is left.
  bool Flush(std::chrono::milliseconds timeout);
  MqttCounters Counters() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Throws MqttError unless `level` can be one level of a topic name: 1 to 64 characters, none
/// of '/', '+', '#' or a control character (MQTT 3.1.1 sec. 4.7: wildcards are for filters).
void CheckTopicLevel(const std::string& level, const std::string& what);

}  // namespace mlp::plant
