#pragma once
/// @file The arguments of `mlp-grind-hal` (the grinding cell as a LinuxCNC HAL component): the
/// job (camera, nominal, wheel, limit), the trigger, the virtual machine's error, the safety
/// limit on a compensation, the sampler's FIFO and its period. Kept out of the program so the
/// parsing is tested without LinuxCNC.

#include "mlp/grind/grind_station.h"

#include <string>
#include <vector>

namespace mlp::host {

struct GrindStationArgs {
  std::string name = "mlp-grind";  ///< the HAL component's name, its pins' prefix
  grind::GrindStationConfig config;
  unsigned seed = 1;                 ///< the frames' noise
  int sampler_channel = 0;           ///< the realtime sampler's FIFO carrying the slide
  long servo_period_ns = 1'000'000;  ///< the sampler's thread period: a sample's time
  int cycle_us = 1000;               ///< how long to wait when the FIFO is empty
};

/// Throws base::UsageError (an option) or grind::GrindInputError (the job file, a value out
/// of range), each naming what is wrong.
GrindStationArgs ParseGrindStationArgs(const std::vector<std::string>& args);
const char* GrindStationUsage();

}  // namespace mlp::host
