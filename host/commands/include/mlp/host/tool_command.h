#pragma once
/// @file `mlp tool ...`: tools measured from their shadow images (seed 000): the strobe plan,
/// the virtual tool camera, the camera's calibration with a pin, the measurement and its
/// tool table update (docs/TOOLCAM.md).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes: 0 done, 2 bad arguments or files, 3 the plan or measurement cannot be made (the
/// reason printed), 4 measured but the tool table not changed (the reason printed).
int RunToolCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
