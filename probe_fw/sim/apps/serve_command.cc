// `mlp-sim serve`: a virtual probe on the network. It connects to the host like a real probe,
// authenticates with its key, and answers capture requests with clouds the real firmware
// reconstructed from rendered frames.

#include "mlp/probe_fw/agent.h"
#include "mlp/sim/machine_world.h"
#include "mlp/sim/scene.h"
#include "mlp/sim/virtual_camera.h"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <stdexcept>

#include "cli.h"
#include "sim_command.h"

namespace mlp::sim {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop = true; }

// A plausible battery for the status reports: 0.02 % per capture from full, board at 35 C.
constexpr double kBatteryPerCapture = 0.02;
constexpr double kBoardTemperatureC = 35.0;

// A HAL pin of the running machine, read as its M-codes read them (halcmd, the environment
// LinuxCNC was started with). popen rather than the HAL library: a component of our own would
// have to be created and torn down at every capture, and the virtual probe must not need
// LinuxCNC's headers to build.
double HalPin(const std::string& name) {
  if (name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789.-_") != std::string::npos)
    throw std::runtime_error("machine: '" + name + "' is not a HAL pin name");
  FILE* p = popen(("halcmd -s getp " + name + " 2>/dev/null").c_str(), "r");
  if (p == nullptr) throw std::runtime_error("machine: cannot run halcmd");
  char text[64] = {};
  const bool read = std::fgets(text, sizeof text, p) != nullptr;
  const int status = pclose(p);
  char* end = nullptr;
  const double v = read ? std::strtod(text, &end) : 0.0;
  if (status != 0 || !read || end == text || !std::isfinite(v))
    throw std::runtime_error("machine: cannot read HAL pin " + name + " (is LinuxCNC running?)");
  return v;
}

// Where the flange truly is on the table: the machine's true axes at the joints the controller
// holds now (the macro asked for this capture at rest), whatever H the host sent.
TruePose FromMachine(const TrunnionWorld& world) {
  return [world](const link::CaptureRequest&) {
    std::array<double, 6> v{};
    for (size_t i = 0; i < 6; ++i) v[i] = HalPin(world.joint_pins[i]);
    return world.TableFromFlange({geometry::Vec3(v[0], v[1], v[2]), v[3], v[4], v[5]});
  };
}

}  // namespace

int RunServeCommand(const std::vector<std::string>& args, std::ostream& out) {
  using probe_fw::cli::UsageError;
  const base::Args o(args, {{"--probe", "--scene", "--host", "--port", "--key", "--seed",
                             "--buffer", "--captures", "--firmware-model", "--machine"},
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
      MakeVirtualCamera(
          probe, static_cast<std::uint64_t>(o.Number("--seed", 1)), projector,
          o.Has("--machine") ? FromMachine(LoadTrunnionWorld(o.Text("--machine"))) : TruePose()),
      &projector, options, g_stop, log);
  out << "mlp-sim: served " << s.captures << " captures (" << s.points << " points), refused "
      << s.refused << ", failed " << s.failed << "\n";
  return probe_fw::cli::kExitOk;
}

}  // namespace mlp::sim
