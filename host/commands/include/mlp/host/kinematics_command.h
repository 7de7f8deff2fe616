#pragma once
/// @file `mlp kinematics` (issue 54): a five-axis trunnion's rotary axes checked from sphere
/// centres measured at a plan of A and C positions, against the kinematics' parameters the
/// machine starts with (its HAL file). docs/KINEMATICS.md, docs/CLI.md.

#include "mlp/calib/trunnion.h"

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes beyond the shared ones.
enum KinematicsExit : int {
  kExitKinematicsOff = 3,       ///< determined, and a pivot or squareness beyond its limit
  kExitUndetermined = 4,        ///< the plan or the centres cannot determine the axes
  kExitCalibrationRefused = 6,  ///< a change beyond the limit, or the machine running
};

/// The pins of `xyzac-trt-kins` from a HAL file's `setp xyzac-trt-kins.<pin> <mm>` lines (the
/// file that sets them when the machine starts; other lines ignored). UsageError when a pin
/// other than tool-offset is missing, given twice or not a finite number.
calib::TrtPins ParseTrtPinsHal(const std::string& text);

/// Sphere centres from a `mlprobe-trunnion-centres/1` JSON file: {"centres": [{"a_deg",
/// "c_deg", "centre_mm": [x, y, z]}, ...]} (machine frame, mm). UsageError when malformed.
std::vector<calib::TrunnionObservation> ParseTrunnionCentres(const std::string& text);

/// mlp kinematics check --centres FILE (--pins HALFILE | --pin NAME=MM ...) [--limit-um U]
///                      [--square-limit-deg D] [--svg FILE] [--json]
/// mlp kinematics calibrate --centres FILE --pins HALFILE [--null-band-um U]
///                          [--max-change-um U] [--write] [--log FILE] [--json]
/// mlp kinematics plan --pins HALFILE --sphere X,Y,Z [...] [--out PROGRAM.ngc] [--json]
/// mlp kinematics flange-pose (--pins HALFILE | --pin NAME=MM ...) --joints X,Y,Z,A,C
///                            [--spindle DEG]
int RunKinematicsCommand(const std::vector<std::string>& args,
                         std::ostream& out,
                         std::ostream& err);

}  // namespace mlp::host
