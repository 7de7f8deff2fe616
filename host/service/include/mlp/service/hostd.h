#pragma once
/// @file mlp-hostd: the probe link (capture broker), the job socket, the history, and the jobs
/// behind the ops (docs/HOSTD.md). One job per machine at a time: a second job for a busy
/// machine waits up to the machine's job timeout, then is refused as busy.

#include "mlp/service/config.h"
#include "mlp/service/job_server.h"

#include <memory>

namespace mlp::service {

class Hostd {
 public:
  /// Opens the history (closing jobs a previous run left running), reads the probes' key files.
  /// Throws ConfigError / std::runtime_error naming what is wrong; nothing is started then.
  Hostd(HostdConfig config, Log log);
  ~Hostd();
  /// Starts the probe link and the job socket; throws when either cannot bind.
  void Start();
  /// Graceful: stops taking requests, lets running jobs reply, stops the link.
  void Stop();
  std::uint16_t LinkPort() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::service
