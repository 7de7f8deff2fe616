#pragma once
/// @file The trunnion's pins in the HAL file that sets them when LinuxCNC starts (issue 54):
/// `setp xyzac-trt-kins.<pin> <mm>` lines, read and rewritten in place so that a restart keeps
/// what a kinematics calibration wrote, every other line of the file as it was.

#include "mlp/calib/trunnion.h"

#include <string>

namespace mlp::calib {

/// The pins from the file's `setp xyzac-trt-kins.<pin> <mm>` lines (other lines ignored).
/// Throws TrunnionError when a pin other than tool-offset is missing, set twice or not a finite
/// number.
TrtPins ParseTrtPinsHal(const std::string& text);

/// The same text with the values of x-rot-point, y-rot-point, y-offset and z-offset set to
/// `pins`' (to 0.1 nm: the file keeps what the fit found), every other byte kept. Throws
/// TrunnionError when the text does not parse (ParseTrtPinsHal) or a pin is not finite.
std::string RewriteTrtPinsHal(const std::string& text, const TrtPins& pins);

}  // namespace mlp::calib
