#pragma once
// Helpers shared by the link's tests: fixed keys, fault capture, and configurations with short
// timers so that faults are noticed within the tests' time bounds.

#include "mlp/link/transport.h"

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::link::testing {

using namespace std::chrono_literals;

inline Key KeyOf(std::uint8_t seed) { return Key{Bytes(32, seed)}; }

/// The fault of the LinkError `f` throws; a test failure when it throws none.
inline LinkFault FaultOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const LinkError& e) {
    return e.fault();
  }
  ADD_FAILURE() << "accepted";
  return LinkFault::kProtocol;
}

inline HostLinkConfig HostConfig(std::map<std::string, Key> probes, Millis idle = 1000ms) {
  HostLinkConfig cfg;
  cfg.probes = std::move(probes);
  cfg.heartbeat = 100ms;
  cfg.idle_timeout = idle;
  return cfg;
}

inline ProbeLinkConfig ProbeConfig(const std::string& serial,
                                   Key key,
                                   std::uint16_t port,
                                   Millis idle = 1000ms) {
  ProbeLinkConfig cfg;
  cfg.serial = serial;
  cfg.key = std::move(key);
  cfg.port = port;
  cfg.heartbeat = 100ms;
  cfg.idle_timeout = idle;
  cfg.backoff_min = 5ms;
  cfg.backoff_max = 200ms;
  cfg.status_period = 200ms;
  return cfg;
}

/// A link's log lines, kept for the test to look for reasons.
struct LogBook {
  std::mutex m;
  std::vector<std::string> log;
  void Log(const std::string& line) {
    std::lock_guard lock(m);
    log.push_back(line);
  }
  bool Logged(const std::string& needle) {
    std::lock_guard lock(m);
    for (const auto& l : log) {
      if (l.find(needle) != std::string::npos) return true;
    }
    return false;
  }
};

}  // namespace mlp::link::testing
