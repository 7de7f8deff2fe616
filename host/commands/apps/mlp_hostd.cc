// mlp-hostd: the host service (docs/HOSTD.md). Thin: reads the configuration, starts the
// service, logs JSON lines on stderr (the journal keeps them), stops gracefully on SIGINT or
// SIGTERM.

#include "mlp/base/clock.h"
#include "mlp/history/history.h"
#include "mlp/host/cli.h"
#include "mlp/service/hostd.h"
#include "mlp/service/request_json.h"

#include <csignal>
#include <iostream>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>
#include <pthread.h>
#include <sys/resource.h>

namespace {

constexpr const char* kUsage =
    "usage: mlp-hostd --config FILE\n"
    "  runs the host service: the probe link, the job socket for `mlp`, the job history\n"
    "  (configuration format: docs/HOSTD.md; example: samples/hostd/hostd.json)\n"
    "exit codes: 0 stopped by SIGINT/SIGTERM, 2 bad configuration or cannot bind, 1 bug\n";

std::mutex log_m;

void Log(const std::string& level, const std::string& message) {
  const std::lock_guard lock(log_m);
  // DumpSafe: a message may quote a peer's bytes that are not UTF-8 (a serial, a file name).
  std::cerr << mlp::service::DumpSafe(
                   {{"time", mlp::base::UtcTimestamp()}, {"level", level}, {"msg", message}})
            << std::endl;
}

// The soft limit on open files up to the hard one: each job-socket client and probe costs a
// descriptor, and the usual soft 1024 is what ran out under a flood (the caps in JobServer and
// the link stay far below the hard limit systemd's LimitNOFILE sets).
void RaiseFileLimit() {
  rlimit l{};
  if (getrlimit(RLIMIT_NOFILE, &l) == 0 && l.rlim_cur < l.rlim_max) {
    l.rlim_cur = l.rlim_max;
    setrlimit(RLIMIT_NOFILE, &l);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() != 2 || args[0] != "--config") {
    (args.size() == 1 && args[0] == "--help" ? std::cout : std::cerr) << kUsage;
    return args.size() == 1 && args[0] == "--help" ? mlp::host::kExitOk : mlp::host::kExitBadInput;
  }
  // Signals go to the main thread's sigwait only: block them before any thread starts.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::signal(SIGPIPE, SIG_IGN);  // a client that hangs up must not kill the service
  std::signal(SIGXFSZ, SIG_IGN);  // a file-size limit is a write error (EFBIG), not death
  RaiseFileLimit();
  try {
    mlp::service::Hostd hostd(mlp::service::LoadHostdConfig(args[1]),
                              [](const std::string& m) { Log("info", m); });
    hostd.Start();
    int signal = 0;
    sigwait(&stop_signals, &signal);
    Log("info", std::string("mlp-hostd: ") + (signal == SIGINT ? "SIGINT" : "SIGTERM") +
                    ": stopping after the running jobs");
    hostd.Stop();
    Log("info", "mlp-hostd: stopped");
    return mlp::host::kExitOk;
  } catch (const mlp::service::ConfigError& e) {
    Log("error", e.what());
  } catch (const std::exception& e) {
    Log("error", std::string("mlp-hostd: cannot start: ") + e.what());
  }
  return mlp::host::kExitBadInput;
}
