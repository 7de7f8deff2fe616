#pragma once
/// @file `mlp setter ...`: the laser tool setter's beam signal (seed 003): the virtual signal,
/// the calibration curve from a pin, the streaming processor's trigger (docs/SETTER.md).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes: 0 done (process: triggered), 2 bad arguments or files, 3 no trigger or no
/// calibration could be made (the reason printed).
int RunSetterCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
