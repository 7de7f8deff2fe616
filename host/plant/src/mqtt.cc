#include "mlp/plant/mqtt.h"

#include "mlp/base/json_text.h"

#include <algorithm>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <thread>

#include <mosquitto.h>

namespace mlp::plant {
namespace {

using json = nlohmann::json;

// libmosquitto's global set-up; once per process, never undone (other clients may live on).
void InitLibrary() {
  static std::once_flag once;
  std::call_once(once, [] { mosquitto_lib_init(); });
}

void CheckReadable(const std::string& path, const std::string& field) {
  if (path.empty()) return;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw MqttError("mqtt." + field + ": no such file " + path);
}

}  // namespace

void CheckTopicLevel(const std::string& level, const std::string& what) {
  constexpr std::size_t kMaxLevel = 64;
  const bool bad_char = std::any_of(level.begin(), level.end(), [](char c) {
    return c == '/' || c == '+' || c == '#' || static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
  });
  if (level.empty() || level.size() > kMaxLevel || bad_char) {
    // Quoted as JSON: a control character in a name must not reach a log line raw.
    std::string message = what;
    message += ' ';
    message += base::json_fields::DumpText(json(level));
    message += " cannot be a topic level: 1 to 64 characters, no '/', '+', '#' or control ones";
    throw MqttError(message);
  }
}

struct MqttPublisher::Impl {
  MqttOptions options;
  MqttLog log;
  mosquitto* client = nullptr;
  mutable std::mutex m;
  std::condition_variable acknowledged;
  MqttCounters counters;
  bool said_down = false;  // the outage is logged once, not at every retry
  // Messages held while the broker is away. libmosquitto refuses a publish without a
  // connection (MOSQ_ERR_NO_CONN, even at QoS 1), so the waiting room is ours; it is drained in
  // order on the network thread when the connection is back, and new messages queue behind it
  // until it is empty.
  struct Waiting {
    std::string topic, text;
    bool retain = false;
  };
  std::deque<Waiting> waiting;
  bool draining = false;
  // libmosquitto's network thread reconnects after a connection is lost, but not when the very
  // first connect fails (tried with 2.0.11: a broker that comes up later is never reached). Until
  // the first TCP connect succeeds, this thread retries; then it starts the network thread.
  std::thread connector;
  bool loop_started = false, stopping = false;
  std::condition_variable stop_wake;

  std::string Broker() const { return options.host + ":" + std::to_string(options.port); }

  void Say(const std::string& line) {
    if (log) log(line);
  }

  static void OnConnect(mosquitto*, void* self, int rc) {
    auto& s = *static_cast<Impl*>(self);
    std::unique_lock lock(s.m);
    s.counters.connected = rc == 0;
    if (rc == 0) {
      s.counters.last_error.clear();
      const bool was_down = s.said_down;
      s.said_down = false;
      s.draining = !s.waiting.empty();
      const std::size_t held = s.waiting.size();
      lock.unlock();
      s.Say("mqtt: connected to " + s.Broker() + (was_down ? " again" : "") +
            (held > 0 ? ", sending " + std::to_string(held) + " messages held meanwhile" : ""));
      s.Drain();
      return;
    }
    s.counters.last_error = mosquitto_connack_string(rc);
    const bool say = !s.said_down;
    s.said_down = true;
    lock.unlock();
    if (say)
      s.Say("mqtt: " + s.Broker() + " refused the connection: " + mosquitto_connack_string(rc));
  }

  static void OnDisconnect(mosquitto*, void* self, int rc) {
    auto& s = *static_cast<Impl*>(self);
    std::unique_lock lock(s.m);
    s.counters.connected = false;
    if (rc == 0) return;  // our own disconnect
    // A refused CONNECT ends in a disconnect too: the broker's reason (OnConnect) stays.
    if (rc != MOSQ_ERR_CONN_REFUSED) s.counters.last_error = mosquitto_strerror(rc);
    const bool say = !s.said_down;
    s.said_down = true;
    lock.unlock();
    if (say)
      s.Say("mqtt: lost " + s.Broker() + " (" + mosquitto_strerror(rc) +
            "); messages wait and the client reconnects");
  }

  static void OnPublish(mosquitto*, void* self, int) {
    auto& s = *static_cast<Impl*>(self);
    {
      std::lock_guard lock(s.m);
      ++s.counters.published;
      --s.counters.queued;
    }
    s.acknowledged.notify_all();
  }

  /// Hands the held messages to the client, oldest first, until none is left or the connection
  /// drops again (the rest waits for the next connect).
  void Drain() {
    for (;;) {
      Waiting next;
      {
        std::lock_guard lock(m);
        if (waiting.empty() || !counters.connected) {
          draining = false;
          return;
        }
        next = std::move(waiting.front());
        waiting.pop_front();
      }
      if (Send(next.topic, next.text, next.retain) == MOSQ_ERR_NO_CONN) {
        std::lock_guard lock(m);
        waiting.push_front(std::move(next));
        draining = false;
        return;
      }
    }
  }

  /// QoS 1. Any error but a missing connection drops the message (counted).
  int Send(const std::string& topic, const std::string& text, bool retain) {
    const int rc = mosquitto_publish(client, nullptr, topic.c_str(), static_cast<int>(text.size()),
                                     text.data(), 1, retain);
    if (rc != MOSQ_ERR_SUCCESS && rc != MOSQ_ERR_NO_CONN) {
      std::lock_guard lock(m);
      --counters.queued;
      ++counters.dropped;
      counters.last_error = mosquitto_strerror(rc);
    }
    return rc;
  }

  /// One TCP connect (the MQTT handshake follows on the network thread). True when made.
  bool TryConnect() {
    const int rc =
        mosquitto_connect_async(client, options.host.c_str(), options.port, options.keepalive_s);
    if (rc == MOSQ_ERR_SUCCESS) {
      if (mosquitto_loop_start(client) != MOSQ_ERR_SUCCESS) {
        Say("mqtt: the client's network thread did not start");
        return false;
      }
      std::lock_guard lock(m);
      loop_started = true;
      return true;
    }
    const std::string why =
        rc == MOSQ_ERR_ERRNO ? "cannot reach the broker" : mosquitto_strerror(rc);
    std::unique_lock lock(m);
    counters.last_error = why;
    const bool say = !said_down;
    said_down = true;
    lock.unlock();
    if (say)
      Say("mqtt: cannot reach " + Broker() + " (" + why +
          "); messages wait and the client keeps trying");
    return false;
  }

  /// Retries every 1 s, doubling to 30 s, until connected or stopped.
  void KeepConnecting() {
    std::chrono::seconds wait(1);
    for (;;) {
      {
        std::unique_lock lock(m);
        if (stop_wake.wait_for(lock, wait, [this] { return stopping; })) return;
      }
      if (TryConnect()) return;
      wait = std::min(wait * 2, std::chrono::seconds(30));
    }
  }

  void Configure() {
    mosquitto_int_option(client, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    if (!options.username.empty() &&
        mosquitto_username_pw_set(client, options.username.c_str(),
                                  options.password.empty() ? nullptr : options.password.c_str()) !=
            MOSQ_ERR_SUCCESS)
      throw MqttError("mqtt.username: refused by the client library");
    if (!options.will_topic.empty()) {
      const std::string text = base::json_fields::DumpText(options.will_payload);
      if (mosquitto_will_set(client, options.will_topic.c_str(), static_cast<int>(text.size()),
                             text.data(), 1, true) != MOSQ_ERR_SUCCESS)
        throw MqttError("mqtt: the last will's topic " + options.will_topic + " is not valid");
    }
    if (!options.tls.ca_file.empty()) {
      const auto opt = [](const std::string& s) { return s.empty() ? nullptr : s.c_str(); };
      // The broker's certificate and host name are checked (SSL_VERIFY_PEER); TLS 1.2 at least.
      if (mosquitto_tls_set(client, options.tls.ca_file.c_str(), nullptr,
                            opt(options.tls.cert_file), opt(options.tls.key_file),
                            nullptr) != MOSQ_ERR_SUCCESS ||
          mosquitto_tls_opts_set(client, 1, "tlsv1.2", nullptr) != MOSQ_ERR_SUCCESS)
        throw MqttError("mqtt.tls: the client library refused the CA, certificate or key");
    }
    mosquitto_reconnect_delay_set(client, 1, 30, true);
    mosquitto_connect_callback_set(client, &OnConnect);
    mosquitto_disconnect_callback_set(client, &OnDisconnect);
    mosquitto_publish_callback_set(client, &OnPublish);
  }
};

MqttPublisher::MqttPublisher(MqttOptions options, MqttLog log) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.options = std::move(options);
  s.log = std::move(log);
  const MqttOptions& o = s.options;
  // MQTT 3.1.1 (3.1.3.1) promises only 23 characters; Mosquitto takes more, and ours are
  // "mlp-hostd-" + a topic level of at most 64.
  constexpr std::size_t kMaxClientId = 128;
  if (o.client_id.empty() || o.client_id.size() > kMaxClientId)
    throw MqttError("mqtt.client_id must be 1 to 128 characters");
  if (o.port < 1 || o.port > 65535) throw MqttError("mqtt.port must be 1..65535");
  if (o.keepalive_s < 5 || o.keepalive_s > 3600)
    throw MqttError("mqtt.keepalive_s must be 5..3600");
  if (o.max_queued < 1) throw MqttError("mqtt.max_queued must be at least 1");
  if (o.tls.ca_file.empty() && !(o.tls.cert_file.empty() && o.tls.key_file.empty()))
    throw MqttError("mqtt.tls: a client certificate needs the CA file too");
  if (o.tls.cert_file.empty() != o.tls.key_file.empty())
    throw MqttError("mqtt.tls: cert_file and key_file go together");
  CheckReadable(o.tls.ca_file, "tls.ca_file");
  CheckReadable(o.tls.cert_file, "tls.cert_file");
  CheckReadable(o.tls.key_file, "tls.key_file");
  InitLibrary();
  s.client = mosquitto_new(o.client_id.c_str(), true, &s);
  if (s.client == nullptr) throw MqttError("mqtt: the client library could not make a client");
  try {
    s.Configure();
  } catch (...) {
    mosquitto_destroy(s.client);
    throw;
  }
  // A broker that is not up is no error here: it is tried again in the background.
  if (!s.TryConnect()) s.connector = std::thread([&s] { s.KeepConnecting(); });
}

MqttPublisher::~MqttPublisher() {
  Impl& s = *impl_;
  {
    std::lock_guard lock(s.m);
    s.stopping = true;
  }
  s.stop_wake.notify_all();
  if (s.connector.joinable()) s.connector.join();
  if (Counters().connected) Flush(std::chrono::seconds(2));
  if (s.loop_started) {
    mosquitto_disconnect(s.client);  // a clean goodbye: the broker keeps the will to itself
    mosquitto_loop_stop(s.client, false);
  }
  mosquitto_destroy(s.client);
}

bool MqttPublisher::Publish(const std::string& topic, const json& payload, bool retain) {
  Impl& s = *impl_;
  Impl::Waiting message{topic, base::json_fields::DumpText(payload), retain};
  {
    std::lock_guard lock(s.m);
    if (s.counters.queued >= s.options.max_queued) {
      ++s.counters.dropped;
      return false;
    }
    ++s.counters.queued;  // before the call: its acknowledgement may come first
    if (!s.counters.connected || s.draining || !s.waiting.empty()) {
      s.waiting.push_back(std::move(message));
      return true;
    }
  }
  const int rc = s.Send(message.topic, message.text, message.retain);
  if (rc == MOSQ_ERR_NO_CONN) {  // the connection dropped just now: held like the others
    std::lock_guard lock(s.m);
    s.waiting.push_back(std::move(message));
    return true;
  }
  return rc == MOSQ_ERR_SUCCESS;
}

bool MqttPublisher::Flush(std::chrono::milliseconds timeout) {
  std::unique_lock lock(impl_->m);
  return impl_->acknowledged.wait_for(lock, timeout, [&] { return impl_->counters.queued == 0; });
}

MqttCounters MqttPublisher::Counters() const {
  std::lock_guard lock(impl_->m);
  return impl_->counters;
}

}  // namespace mlp::plant
