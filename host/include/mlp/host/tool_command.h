#pragma once
/// @file `mlp tool ...`: tools measured from their shadow images (seed 000). `mlp tool strobe`
/// plans the strobe for a tool turning in the spindle (docs/TOOLCAM.md).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes: 0 planned, 2 bad arguments, 3 the plan cannot be made (the reason printed).
int RunToolCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
