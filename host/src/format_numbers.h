#pragma once
// Numbers for the human summaries of the command-line tools (internal to mlp_host_calibrate).

#include "mlp/geometry/types.h"

#include <iomanip>
#include <sstream>
#include <string>

namespace mlp::host {

inline std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

inline std::string Vec(const geometry::Vec3& v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << "(" << v.x() << ", " << v.y() << ", " << v.z()
    << ")";
  return s.str();
}

}  // namespace mlp::host
