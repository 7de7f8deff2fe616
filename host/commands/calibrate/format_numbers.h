#pragma once
// Numbers for the human summaries of the command-line tools (internal to mlp_host_calibrate).

#include "mlp/geometry/types.h"
#include "mlp/host/cli.h"  // Fixed

#include <ctime>
#include <iomanip>
#include <sstream>
#include <string>

namespace mlp::host {

inline std::string Vec(const geometry::Vec3& v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << "(" << v.x() << ", " << v.y() << ", " << v.z()
    << ")";
  return s.str();
}

/// A calibration id of a probe, e.g. "MLP-1-optics-20261125T101500Z" (UTC, to the second).
inline std::string DefaultCalibrationId(const std::string& serial, const std::string& what) {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &utc);
  return serial + "-" + what + "-" + stamp;
}

}  // namespace mlp::host
