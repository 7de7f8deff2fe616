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
#include "mlp/link/messages.h"

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mlp::link {

using Log = std::function<void(const std::string& line)>;
using Millis = std::chrono::milliseconds;

struct HostLinkConfig {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 0;             ///< 0: any free port (see HostLink::Port)
  std::map<std::string, Key> probes;  ///< the known probe serials and their keys
  /// From connecting to authenticated, at most, however the bytes trickle in.
  Millis handshake_timeout{3000};
  Millis idle_timeout{3000};  ///< no frame for this long: the connection is dropped
  Millis heartbeat{500};
  /// Connections open at once (a bound on file descriptors): the probes' sessions and the
  /// handshakes in progress; more are closed at once.
  std::size_t max_connections = 64;
  /// Peers in their handshake at once; a new one closes the oldest (docs/LINK.md, "Limits").
  std::size_t max_handshakes = 8;
  /// (serial, capture id) pairs kept for de-duplication
  std::size_t remembered_captures = 1u << 20;
};

struct HostLinkStats {
  std::uint64_t connections = 0, authenticated = 0, delivered = 0, duplicates = 0, rejected = 0;
  std::uint64_t unwanted = 0;  ///< clouds the admission turned away
  /// Clouds whose header read but whose body did not (acknowledged, reported to the capture).
  std::uint64_t malformed = 0;
};

class HostLink {
 public:
  /// Called on the link's thread, once per capture id.
  using CloudHandler = std::function<void(const LinkCloud& cloud)>;
  using StatusHandler = std::function<void(const std::string& serial, const ProbeStatus& status)>;
  using ErrorHandler = std::function<void(const std::string& serial, const ProbeError& error)>;
  HostLink(HostLinkConfig config, CloudHandler on_cloud, Log log);
  ~HostLink();
  /// Asked on the link's thread, before a CLOUD's points are decompressed and decoded: the
  /// serial the session authenticated and the cloud's header. Returns an empty string to take
  /// the cloud, otherwise the reason it is not wanted: the cloud is then acknowledged (the probe
  /// may drop it), logged (throttled) and neither decoded nor remembered as seen, so the real
  /// cloud for that capture id still gets through.
  using Admission = std::function<std::string(const std::string& serial, const CloudHeader& head)>;
  /// Optional, before Start; called on the link's thread. Errors are logged either way.
  void OnStatus(StatusHandler handler);
  void OnError(ErrorHandler handler);
  /// Optional, before Start; without it every cloud of an authenticated probe is taken.
  void SetAdmission(Admission admission);
  /// Thread-safe. Sends the request to the probe if it is connected and authenticated: true when
  /// it was queued for sending, false when the probe is not connected (the job fails or waits).
  /// Throws LinkError (kMalformedPayload) for a request the probe would refuse anyway.
  bool RequestCapture(const std::string& serial, const CaptureRequest& request);
  /// Thread-safe. The probe's last reported status, if it reported one since the host started.
  std::optional<ProbeStatus> LatestStatus(const std::string& serial) const;
  /// Thread-safe. Serials with an authenticated connection now, sorted.
  std::vector<std::string> ConnectedProbes() const;
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
  Millis status_period{2000};     ///< STATUS to the host this often, and on every change of note
  std::size_t request_queue = 8;  ///< capture requests waiting for the firmware, at most
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
  /// Thread-safe. A cloud already encoded (EncodeCloud's bytes), sent as they are: what a
  /// stand-in probe uses to send the host what a faulty or hostile firmware could.
  SubmitResult SubmitEncoded(const std::string& capture_id, Bytes payload);
  std::size_t Unacknowledged() const;
  /// Thread-safe. The next capture request from the host, or nothing after `timeout`. Requests
  /// that arrive while the buffer is full are refused by the link itself (ERROR buffer_full),
  /// as are requests beyond `request_queue` (ERROR busy) and malformed ones (ERROR bad_request).
  std::optional<CaptureRequest> NextRequest(Millis timeout);
  /// Thread-safe. Tells the host that a request failed; sent if a session is up (the host's job
  /// times out otherwise), logged either way. A long message is clipped.
  void ReportError(ProbeError error);
  /// Battery, temperature and flags for STATUS (the link fills in the buffer fields). Before
  /// Start; without it STATUS reports the buffer only.
  void SetStatusSource(std::function<ProbeStatus()> source);
  /// True once every submitted cloud is acknowledged, false on timeout.
  bool WaitAllAcknowledged(Millis timeout) const;
  std::uint64_t Reconnects() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::link
