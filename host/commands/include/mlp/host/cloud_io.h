#pragma once
/// @file Reading point clouds from files: `.xyz`/`.txt` (whitespace-separated x y z per line,
/// `#` comments), `.pcd` and `.ply` (read with PCL through a plug-in loaded on first use, so
/// programs that never read them do not pay PCL's start-up cost), or "-" for text on stdin.

#include "mlp/base/input_error.h"
#include "mlp/geometry/types.h"

#include <stdexcept>
#include <string>

namespace mlp::host {

class CloudIoError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct Cloud {
  geometry::Points3 points;       ///< in the file's units
  size_t dropped_non_finite = 0;  ///< NaN/inf points removed (organised clouds mark holes so)
};

/// Reads a cloud; throws CloudIoError with a one-line reason (missing file, parse error with line
/// number, unknown extension, plug-in missing).
Cloud ReadCloud(const std::string& path);

/// Parses whitespace-separated text, three numbers per line; throws CloudIoError.
Cloud ParseXyzText(std::istream& in, const std::string& name);

}  // namespace mlp::host
