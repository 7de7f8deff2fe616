#pragma once
// The ISO 10360-6 circle in space (fit_circle_space.cc), refined from the plane-then-circle fit.

#include "mlp/geometry/fit.h"

namespace mlp::geometry::internal {

/// The circle minimising the squared 3D distances, from `in_plane` (the plane-then-circle fit
/// of the same points). Throws kNotConverged (unless options allow it) or kDegenerate.
FitResult<Circle3> RefineCircle3InSpace(const Points3& points,
                                        const FitResult<Circle3>& in_plane,
                                        const FitOptions& options);

}  // namespace mlp::geometry::internal
