// `mlp status` under load (issue 48's figure): a real mlp-hostd on a temporary folder, 50 client
// threads each sending status requests over the job socket as fast as they are answered, and
// meanwhile `mlp status` run as a process 100 times, its wall time per call. The baseline in the
// same run: the same 100 calls with the service idle. Prints p50 / p95 / max of both, their
// ratio, the requests the load made and the service's resident memory before and after.
// Usage: mlp_status_load [SECONDS (20)] [CLIENTS (50)]

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <utility>  // before Asio (Boost 1.74 needs std::exchange)
#include <vector>

#include <boost/asio.hpp>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;
namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;
using local = asio::local::stream_protocol;

constexpr int kCalls = 100;  // `mlp status` processes per phase

double Ms(Clock::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

double RssMb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

// One status request and its reply over the socket; false when it failed.
bool RawStatus(const std::string& socket) {
  asio::io_context io;
  local::socket s(io);
  boost::system::error_code ec;
  s.connect(local::endpoint(socket), ec);
  if (ec) return false;
  asio::write(s, asio::buffer(std::string("{\"op\": \"status\"}\n")), ec);
  asio::streambuf b;
  asio::read_until(s, b, '\n', ec);
  return !ec;
}

struct Percentiles {
  double p50, p95, max;
  int failed;
};

// kCalls runs of `mlp status --socket S`, each timed whole (process start included).
Percentiles TimeCli(const std::string& mlp, const std::string& socket) {
  std::vector<double> ms;
  int failed = 0;
  const std::string command = mlp + " status --socket " + socket + " > /dev/null 2>&1";
  for (int i = 0; i < kCalls; ++i) {
    const auto t0 = Clock::now();
    failed += std::system(command.c_str()) != 0;
    ms.push_back(Ms(Clock::now() - t0));
  }
  std::sort(ms.begin(), ms.end());
  return {ms[ms.size() / 2], ms[ms.size() * 95 / 100], ms.back(), failed};
}

}  // namespace

int main(int argc, char** argv) {
  const int seconds = argc > 1 ? std::atoi(argv[1]) : 20;
  const int clients = argc > 2 ? std::atoi(argv[2]) : 50;
  const fs::path dir = fs::temp_directory_path() / "mlp_status_load";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "probe.key") << std::string(64, 'a') << "\n";
  fs::permissions(dir / "probe.key", fs::perms::owner_read | fs::perms::owner_write);
  std::ofstream(dir / "hostd.json")
      << R"({"format": "mlprobe-hostd/1", "data_dir": "data", "job_socket": "run/jobs.sock",
  "probe_link": {"address": "127.0.0.1", "port": 17499},
  "probes": [{"serial": "MLP-REF-0001", "key_file": "probe.key"}],
  "machines": [{"name": "vmc-1", "probe": "MLP-REF-0001",
                "controller": {"kind": "files", "result_dir": "out"}}]})";
  const std::string socket = (dir / "run" / "jobs.sock").string();
  const pid_t hostd = fork();
  if (hostd == 0) {
    std::freopen((dir / "hostd.log").c_str(), "w", stderr);
    execl(MLP_HOSTD, MLP_HOSTD, "--config", (dir / "hostd.json").c_str(), nullptr);
    _exit(127);
  }
  while (!RawStatus(socket)) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::printf("mlp status, %d calls, service idle (baseline)...\n", kCalls);
  const Percentiles idle = TimeCli(MLP_CLI, socket);
  const double rss_before = RssMb(hostd);
  std::atomic<bool> stop{false};
  std::atomic<long> requests{0}, failures{0};
  std::vector<std::thread> load;
  for (int c = 0; c < clients; ++c)
    load.emplace_back([&] {
      while (!stop) (RawStatus(socket) ? requests : failures)++;
    });
  std::printf("%d clients sending status for %d s; meanwhile mlp status, %d calls...\n", clients,
              seconds, kCalls);
  const auto t0 = Clock::now();
  const Percentiles loaded = TimeCli(MLP_CLI, socket);
  std::this_thread::sleep_until(t0 + std::chrono::seconds(seconds));
  stop = true;
  for (auto& t : load) t.join();
  const double rss_after = RssMb(hostd);
  kill(hostd, SIGTERM);
  waitpid(hostd, nullptr, 0);
  std::printf("\n| `mlp status` (process, wall) | p50 ms | p95 ms | max ms | failed |\n");
  std::printf("| --- | --- | --- | --- | --- |\n");
  std::printf("| idle service (baseline) | %.1f | %.1f | %.1f | %d |\n", idle.p50, idle.p95,
              idle.max, idle.failed);
  std::printf("| under %d clients | %.1f | %.1f | %.1f | %d |\n", clients, loaded.p50, loaded.p95,
              loaded.max, loaded.failed);
  std::printf(
      "\np95 ratio loaded / idle: %.2f; load: %ld requests answered in %d s, %ld failed; "
      "mlp-hostd resident %.1f MB before, %.1f MB after\n",
      loaded.p95 / idle.p95, requests.load(), seconds, failures.load(), rss_before, rss_after);
  return loaded.failed == 0 ? 0 : 1;
}
