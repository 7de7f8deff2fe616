#include "board.h"

#include <algorithm>
#include <fstream>
#include <memory>

namespace mlp::probe_fw {
namespace {

// One number from a sysfs file, or nothing.
std::optional<double> ReadNumber(const std::string& path) {
  std::ifstream in(path);
  double v = 0.0;
  if (in >> v) return v;
  return std::nullopt;
}

}  // namespace

std::unique_ptr<Projector> OpenBoardProjector(const base::Args& o, const ProbeModel& probe) {
  LinuxProjectorConfig c;
  c.spi_device = o.Text("--spi", c.spi_device);
  c.gpio_chip = o.Text("--gpio-chip", c.gpio_chip);
  const double laser = o.Number("--laser-line", c.laser_line);
  const double led = o.Number("--led-line", c.led_line);
  if (!(laser >= 0 && laser < 512 && led >= 0 && led < 512) || laser == led) {
    throw cli::UsageError("--laser-line and --led-line are two different lines 0..511");
  }
  c.laser_line = static_cast<std::uint32_t>(laser);
  c.led_line = static_cast<std::uint32_t>(led);
  c.max_column = probe.projector.columns - 1.0;
  return OpenLinuxProjector(c);
}

std::function<BoardReading(const AgentStats&)> BoardReadings(const base::Args& o,
                                                             const link::Log& log) {
  const std::string battery = o.Text("--battery", "/sys/class/power_supply/BAT0");
  const std::string thermal = o.Text("--thermal", "/sys/class/thermal/thermal_zone0/temp");
  auto warned = std::make_shared<bool>(false);
  return [battery, thermal, warned, log](const AgentStats&) {
    BoardReading r;
    const auto capacity = ReadNumber(battery + "/capacity");
    const auto millidegrees = ReadNumber(thermal);
    if (capacity) r.battery_percent = static_cast<std::uint8_t>(std::clamp(*capacity, 0.0, 100.0));
    if (millidegrees) r.temperature_c = std::clamp(*millidegrees / 1000.0, -40.0, 125.0);
    std::ifstream status(battery + "/status");
    std::string state;
    r.charging = (status >> state) && state == "Charging";
    if ((!capacity || !millidegrees) && !*warned) {
      *warned = true;
      log(std::string("status: no ") + (!capacity ? "battery gauge at " + battery : "") +
          (!capacity && !millidegrees ? ", no " : "") +
          (!millidegrees ? "temperature at " + thermal : "") + "; reporting nominal values");
    }
    return r;
  };
}

}  // namespace mlp::probe_fw
