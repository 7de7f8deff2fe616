#pragma once
/// @file `mlp calibrate hand-eye|recheck|list`: calibration from captures on disk (the host
/// service drives the same code over the probe link). Built into its own program,
/// `mlp-calibrate`, which `mlp calibrate` runs: calibration links Ceres and OpenCV, and the
/// macro-facing `mlp` must not pay their start-up on every call.

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes beyond kExitOk / kExitInternal / kExitBadInput (cli.h).
enum CalibrateExit : int {
  kExitUnderDetermined = 3,  ///< the captures do not determine the calibration; nothing stored
  kExitFullCalibrationRequired = 4,  ///< recheck: the change is too large for a quick fix
  kExitFlagged = 5,  ///< map: the clouds are written, an image is flagged (retake it);
                     ///< board-pose: an image disagrees with the calibration
};

/// Runs `mlp calibrate ARGS...` (args exclude "calibrate").
int RunCalibrateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
