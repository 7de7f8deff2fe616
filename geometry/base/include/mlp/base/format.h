#pragma once
/// @file Numbers as people read them in reports and pictures.

#include <iomanip>
#include <sstream>
#include <string>

namespace mlp::base {

/// `v` with `digits` decimals ("0.0123").
inline std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

}  // namespace mlp::base
