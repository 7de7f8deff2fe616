#pragma once
/// @file Captures as calls: a job asks for a cloud and waits for it. The broker owns the host's
/// side of the probe link, sends the capture request and hands back the cloud that comes under
/// that capture id, the probe's typed error for it, or a timeout. Clouds nobody waits for (a
/// capture that timed out, a resend after a restart) are acknowledged by the link and dropped
/// here with a log line: a job never gets a cloud it did not ask for.

#include "mlp/link/transport.h"

#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

namespace mlp::service {

class CaptureError : public std::runtime_error {
 public:
  enum class Kind { kProbeNotConnected, kProbeError, kTimeout, kBadRequest };
  CaptureError(Kind kind, const std::string& what) : std::runtime_error(what), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

class CaptureBroker {
 public:
  CaptureBroker(link::HostLinkConfig config, const link::Log& log);
  ~CaptureBroker();
  void Start();  ///< binds the probe link; throws link::LinkError when it cannot
  void Stop();
  /// Captures waiting now fail at once ("the host is stopping"), and new ones are refused: a
  /// stop does not wait out capture timeouts.
  void FailWaiting();
  std::uint16_t Port() const;

  /// Thread-safe; blocks the calling job until the cloud for `request.capture_id` arrives.
  /// Throws CaptureError: the probe is not connected, it answered with an error (its code and
  /// message), nothing came within `timeout`, or the request is malformed. Capture ids must be
  /// unique among the captures in flight.
  link::LinkCloud Capture(const std::string& serial,
                          const link::CaptureRequest& request,
                          std::chrono::milliseconds timeout);

  std::vector<std::string> ConnectedProbes() const;
  std::optional<link::ProbeStatus> LatestStatus(const std::string& serial) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::service
