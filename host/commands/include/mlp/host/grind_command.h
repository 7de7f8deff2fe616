#pragma once
/// @file `mlp grind ...`: profile error during curve grinding from back-lit frames (seed 001):
/// the virtual frames of a sweep of machine errors, and the measurement of a job's cutting
/// points into compensation vectors and a picture (docs/GRIND.md).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes: 0 done, 2 bad arguments or files, 3 a point could not be measured (the reason).
int RunGrindCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
