#pragma once
/// @file Reading hand-eye inputs from disk: OpenCV FileStorage profiles (a line scanner's
/// x y z triplets, NaN where it saw nothing) and robot pose lists.

#include "mlp/geometry/types.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::calib {

class CaptureIoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The flat x y z list under `key` of an OpenCV FileStorage file (YAML, XML or JSON), as
/// points [mm]; NaN entries are kept (the fit drops them). Throws CaptureIoError.
geometry::Points3 LoadFileStorageProfile(const std::string& path, const std::string& key);

/// Lines of "x y z w p r" (mm, degrees; R = Rz(r) Ry(p) Rx(w)), one pose per line. Throws
/// CaptureIoError naming the line of anything else.
std::vector<geometry::Pose3> LoadXyzWprPoses(const std::string& path);

}  // namespace mlp::calib
