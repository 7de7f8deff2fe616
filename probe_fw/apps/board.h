#pragma once
// The probe board's hardware as `mlp-fw` options: the projector's drivers and the battery and
// temperature readings the status reports. Programs only.

#include "mlp/probe_fw/agent.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/projector.h"

#include <memory>
#include <string>

#include "cli.h"

namespace mlp::probe_fw {

/// `--spi DEV --gpio-chip DEV --laser-line N --led-line N` (defaults: LinuxProjectorConfig),
/// the mirror's range from the probe model. Throws ProjectorError when a device is missing.
std::unique_ptr<Projector> OpenBoardProjector(const base::Args& o, const ProbeModel& probe);

/// Battery and temperature from the kernel's power-supply and thermal classes
/// (`--battery DIR`, default /sys/class/power_supply/BAT0; `--thermal FILE`, default
/// /sys/class/thermal/thermal_zone0/temp). A missing reading reports full / 25 C and is
/// logged once: a board without a gauge still serves.
std::function<BoardReading(const AgentStats&)> BoardReadings(const base::Args& o,
                                                             const link::Log& log);

}  // namespace mlp::probe_fw
