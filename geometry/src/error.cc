#include "mlp/geometry/error.h"

namespace mlp::geometry {

const char* ToString(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument:
      return "invalid_argument";
    case ErrorCode::kTooFewPoints:
      return "too_few_points";
    case ErrorCode::kNonFinite:
      return "non_finite";
    case ErrorCode::kDegenerate:
      return "degenerate";
    case ErrorCode::kNotConverged:
      return "not_converged";
    case ErrorCode::kUnbounded:
      return "unbounded";
  }
  return "unknown";
}

GeometryError::GeometryError(ErrorCode code, const std::string& message)
    : std::runtime_error(message), code_(code) {}

}  // namespace mlp::geometry
