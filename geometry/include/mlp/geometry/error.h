#pragma once
/// @file The one error type of the geometry layer. Every fit either returns a finite result or
/// throws GeometryError; no NaN ever leaves a fit.

#include <stdexcept>
#include <string>

namespace mlp::geometry {

enum class ErrorCode {
  kInvalidArgument,  ///< an option or argument is out of range
  kTooFewPoints,     ///< fewer points than the shape needs
  kNonFinite,        ///< NaN or infinity in the input
  kDegenerate,       ///< the points do not determine the shape (collinear, coincident, ...)
  kNotConverged,     ///< the iterative solver did not reach a stationary point
  kUnbounded,        ///< the problem has no finite solution (e.g. inscribed circle of an arc)
};

/// Stable machine-readable name of a code, e.g. "degenerate".
const char* ToString(ErrorCode code);

class GeometryError : public std::runtime_error {
 public:
  GeometryError(ErrorCode code, const std::string& message);
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

}  // namespace mlp::geometry
