// `mlp-sim serve`: a virtual probe on the network. It connects to the host like a real probe,
// authenticates with its key, and answers capture requests with clouds the real firmware
// reconstructed from rendered frames.

#include "mlp/probe_fw/agent.h"
#include "mlp/probe_fw/cli.h"
#include "mlp/sim/scene.h"
#include "mlp/sim/sim_command.h"
#include "mlp/sim/virtual_camera.h"

#include <atomic>
#include <csignal>
#include <thread>

namespace mlp::sim {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop = true; }

// A plausible battery for the status reports: 0.02 % per capture from full, board at 35 C.
constexpr double kBatteryPerCapture = 0.02;
constexpr double kBoardTemperatureC = 35.0;

}  // namespace

int RunServeCommand(const std::vector<std::string>& args, std::ostream& out) {
  using probe_fw::cli::UsageError;
  const probe_fw::cli::Options o(
      args, {"--probe", "--scene", "--host", "--port", "--key", "--seed", "--buffer", "--captures"},
      {});
  auto probe = std::make_shared<const VirtualProbe>(probe_fw::LoadProbeModel(o.Required("--probe")),
                                                    LoadScene(o.Required("--scene")));
  const double port = o.Number("--port", 0.0);
  if (!(port >= 1.0 && port <= 65535.0)) throw UsageError("--port must be 1..65535");
  link::ProbeLinkConfig cfg;
  cfg.host = o.Get("--host", "127.0.0.1");
  cfg.port = static_cast<std::uint16_t>(port);
  cfg.serial = probe->model().serial;
  cfg.key = link::LoadKeyFile(o.Required("--key"));
  cfg.buffer_clouds = static_cast<std::size_t>(o.Number("--buffer", 64));
  const double max_captures = o.Number("--captures", 0.0);  // 0: serve until a signal
  link::Log log = [&out](const std::string& line) { out << line << "\n" << std::flush; };
  link::ProbeLink link(cfg, log);
  probe_fw::ProbeAgent agent(
      probe->model(), &link,
      MakeVirtualCamera(probe, static_cast<std::uint64_t>(o.Number("--seed", 1))), log);
  link.SetStatusSource([&agent] {
    link::ProbeStatus s;
    const double used = kBatteryPerCapture * static_cast<double>(agent.Stats().captures);
    s.battery_percent = static_cast<std::uint8_t>(std::max(0.0, 100.0 - used));
    s.temperature_c = kBoardTemperatureC;
    return s;
  });
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  out << "mlp-sim: virtual probe " << cfg.serial << " serving " << cfg.host << ":" << cfg.port
      << "\n"
      << std::flush;
  link.Start();
  std::thread watcher([&] {
    while (!g_stop) {
      if (max_captures > 0 && agent.Stats().captures >= max_captures &&
          link.WaitAllAcknowledged(link::Millis(100)))
        g_stop = true;
      std::this_thread::sleep_for(link::Millis(50));
    }
  });
  agent.Serve(g_stop);
  watcher.join();
  link.Stop();
  const probe_fw::AgentStats s = agent.Stats();
  out << "mlp-sim: served " << s.captures << " captures (" << s.points << " points), refused "
      << s.refused << ", failed " << s.failed << "; " << link.Unacknowledged()
      << " clouds not acknowledged\n";
  return probe_fw::cli::kExitOk;
}

}  // namespace mlp::sim
