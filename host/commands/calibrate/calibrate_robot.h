#pragma once
// `mlp calibrate line-laser|board-hand-eye|map`: a camera with a fixed line laser on a robot,
// from images of a fixed chessboard (issue 18). Internal to mlp_host_calibrate;
// calibrate_command.cc dispatches here.

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// args[0] is "line-laser", "board-hand-eye" or "map". Throws UsageError and the calibration
/// library's errors (RunCalibrateCommand reports them and chooses the exit code).
int RunRobotViewsCommand(const std::vector<std::string>& args,
                         std::ostream& out,
                         std::ostream& err);

}  // namespace mlp::host
