#pragma once
/// @file What every fit reports besides its parameters (DESIGN.md "Metrology first").

#include "mlp/geometry/types.h"

#include <string>
#include <vector>

namespace mlp::geometry {

/// Residual statistics of a fit. Residuals are signed orthogonal distances [mm]
/// (positive outside / along the normal); for a 3D line they are unsigned distances.
struct FitStats {
  int n = 0;                  ///< number of points used
  double rms = 0.0;           ///< sqrt(sum r^2 / n) [mm]
  double min_residual = 0.0;  ///< most negative signed residual [mm]
  double max_residual = 0.0;  ///< most positive signed residual [mm]
  int iterations = 0;         ///< solver iterations (0 for closed-form fits)
  /// False only when FitOptions::require_convergence is off and the iteration limit came
  /// before a stationary point: the shape is then the last iterate (finite, valid), an
  /// estimate for the caller's own judgement (the jobs' gate refuses to write from it).
  bool converged = true;
};

/// Parameter covariance sigma^2 (J^T J)^-1 with sigma^2 = SS / (m - p), in the named local
/// parameters (mm and rad). Local parameters are offsets/tilts along the fit's own `u`, `v`
/// directions, which are reported with it.
struct Covariance {
  std::vector<std::string> parameters;
  Eigen::MatrixXd matrix;
  Vec3 u = Vec3::UnitX();  ///< first direction across the axis / normal (3D shapes)
  Vec3 v = Vec3::UnitY();  ///< second direction, u x v = axis or normal
  /// Standard deviation of the named parameter, or -1 if not present.
  double StdDev(const std::string& name) const;
};

/// A fitted shape with its residual statistics and parameter covariance.
template <class Shape>
struct FitResult {
  Shape shape;
  FitStats stats;
  Covariance covariance;
};

}  // namespace mlp::geometry
