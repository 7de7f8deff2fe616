// `mlp-sim serve`: a virtual probe on the network. It connects to the host like a real probe,
// authenticates with its key, and answers capture requests with clouds the real firmware
// reconstructed from rendered frames.

#include "mlp/probe_fw/agent.h"
#include "mlp/sim/scene.h"
#include "mlp/sim/virtual_camera.h"

#include <atomic>
#include <csignal>

#include "cli.h"
#include "sim_command.h"

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
  const base::Args o(args, {{"--probe", "--scene", "--host", "--port", "--key", "--seed",
                             "--buffer", "--captures", "--firmware-model"},
                            {}});
  // The frames come from the probe as built; its firmware knows only a model (the calibrated
  // one): an as-built file is never given to the firmware.
  const AsBuiltProbe as_built = LoadAsBuilt(o.Text("--probe"));
  if (!as_built.plain_model && !o.Has("--firmware-model"))
    throw UsageError(
        "--probe is an as-built file, which the firmware must not know: give the firmware its "
        "probe model (the calibrated file) with --firmware-model");
  const probe_fw::ProbeModel firmware_model =
      o.Has("--firmware-model") ? probe_fw::LoadProbeModel(o.Text("--firmware-model", ""))
                                : as_built.model;
  auto probe = std::make_shared<const VirtualProbe>(as_built, LoadScene(o.Text("--scene")));
  const double port = o.Number("--port", 0.0);
  if (!(port >= 1.0 && port <= 65535.0)) throw UsageError("--port must be 1..65535");
  probe_fw::ServeOptions options;
  options.link.host = o.Text("--host", "127.0.0.1");
  options.link.port = static_cast<std::uint16_t>(port);
  options.link.serial = firmware_model.serial;
  options.link.key = link::LoadKeyFile(o.Text("--key"));
  options.link.buffer_clouds = static_cast<std::size_t>(o.Number("--buffer", 64));
  options.max_captures =
      static_cast<std::uint64_t>(o.Number("--captures", 0.0));  // 0: until a signal
  options.board = [](const probe_fw::AgentStats& stats) {
    probe_fw::BoardReading r;
    const double used = kBatteryPerCapture * static_cast<double>(stats.captures);
    r.battery_percent = static_cast<std::uint8_t>(std::max(0.0, 100.0 - used));
    r.temperature_c = kBoardTemperatureC;
    return r;
  };
  link::Log log = [&out](const std::string& line) { out << line << "\n" << std::flush; };
  // The same agent as the board's (mlp-fw serve), with the virtual mirror and camera plugged in.
  probe_fw::VirtualProjector projector(firmware_model.projector.columns - 1.0);
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  out << "mlp-sim: virtual probe " << options.link.serial << " serving " << options.link.host << ":"
      << options.link.port << "\n"
      << std::flush;
  const probe_fw::AgentStats s = probe_fw::ServeProbe(
      firmware_model,
      MakeVirtualCamera(probe, static_cast<std::uint64_t>(o.Number("--seed", 1)), projector),
      &projector, options, g_stop, log);
  out << "mlp-sim: served " << s.captures << " captures (" << s.points << " points), refused "
      << s.refused << ", failed " << s.failed << "\n";
  return probe_fw::cli::kExitOk;
}

}  // namespace mlp::sim
