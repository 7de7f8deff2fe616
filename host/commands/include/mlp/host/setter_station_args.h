#pragma once
/// @file The arguments of `mlp-setter-hal` (the setter as a LinuxCNC HAL component): the
/// virtual beam and tool, the processor and its curve, the cycle. Kept out of the program so
/// the parsing is tested without LinuxCNC.

#include "mlp/setter/setter_station.h"

#include <string>
#include <vector>

namespace mlp::host {

struct SetterStationArgs {
  std::string name = "mlp-setter";  ///< the HAL component's name, its pins' prefix
  setter::SetterStationConfig config;
  unsigned seed = 1;  ///< the virtual beam's noise and drops; one more per measurement
  int cycle_us = 200;
};

/// Throws base::UsageError (an option) or setter::SetterInputError (the curve file, a model
/// out of range), each naming what is wrong.
SetterStationArgs ParseSetterStationArgs(const std::vector<std::string>& args);
const char* SetterStationUsage();

/// Radii > 0 separated by commas ("3.0,3.01"); UsageError naming `option` otherwise.
std::vector<double> ParseRadiiList(const std::string& option, const std::string& list);

}  // namespace mlp::host
