#pragma once
/// @file The link over TCP (Boost.Asio, one I/O thread per side; Asio stays out of this header).
///
/// Probe side: clouds go into a bounded store-and-forward buffer and stay there until the host
/// acknowledges their capture id; after any failure the probe reconnects with exponential
/// back-off, authenticates again and resends everything unacknowledged, in order. When the
/// buffer is full, Submit refuses the new cloud (the measurement is repeated) instead of
/// dropping an old one. Host side: accepts only on its configured address and port and only
/// known serials, hands each capture id to the application once (de-duplication: resends are
/// acknowledged again but not delivered twice), logs every rejected frame with its reason and
/// keeps serving. Both sides send heartbeats and drop a connection that stays silent.

#include "mlp/link/auth.h"
#include "mlp/link/cloud_codec.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace mlp::link {

using Log = std::function<void(const std::string& line)>;
using Millis = std::chrono::milliseconds;

struct HostLinkConfig {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 0;             ///< 0: any free port (see HostLink::Port)
  std::map<std::string, Key> probes;  ///< the known probe serials and their keys
  Millis handshake_timeout{3000};
  Millis idle_timeout{3000};  ///< no frame for this long: the connection is dropped
  Millis heartbeat{500};
  std::size_t max_connections = 16;
  std::size_t remembered_captures = 1u << 20;  ///< capture ids kept for de-duplication
};

struct HostLinkStats {
  std::uint64_t connections = 0, authenticated = 0, delivered = 0, duplicates = 0, rejected = 0;
};

class HostLink {
 public:
  /// Called on the link's thread, once per capture id.
  using CloudHandler = std::function<void(const LinkCloud& cloud)>;
  HostLink(HostLinkConfig config, CloudHandler on_cloud, Log log);
  ~HostLink();
  /// Binds and starts serving; throws LinkError (kProtocol) when the address cannot be bound.
  void Start();
  void Stop();
  std::uint16_t Port() const;
  HostLinkStats Stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct ProbeLinkConfig {
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;
  std::string serial;
  Key key;
  std::size_t buffer_clouds = 64;  ///< store-and-forward capacity
  bool compress = true;
  Millis heartbeat{500};
  Millis idle_timeout{3000};
  Millis connect_timeout{2000};
  Millis backoff_min{20};
  Millis backoff_max{2000};
};

enum class SubmitResult { kQueued, kBufferFull, kDuplicate };

class ProbeLink {
 public:
  ProbeLink(ProbeLinkConfig config, Log log);
  ~ProbeLink();
  void Start();
  void Stop();
  /// Thread-safe. kBufferFull: nothing was queued, the capture must wait or be repeated.
  SubmitResult Submit(const LinkCloud& cloud);
  std::size_t Unacknowledged() const;
  /// True once every submitted cloud is acknowledged, false on timeout.
  bool WaitAllAcknowledged(Millis timeout) const;
  std::uint64_t Reconnects() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::link
