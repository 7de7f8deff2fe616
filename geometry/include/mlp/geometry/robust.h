#pragma once
/// @file Robust fits for laser clouds (spurious reflections at edges, specks, background).
///
/// Consensus start: random minimal samples fitted by least squares and scored on the whole
/// cloud (MSAC, Torr & Zisserman 2000, with a given threshold; LMedS, Rousseeuw 1984, without
/// one). Then iterative trimming: points within the threshold are refitted by least squares and
/// re-selected until the inlier set is stable. The final result is the ordinary least-squares
/// fit of the inliers, so its statistics and covariance keep their meaning.
///
/// Errors: GeometryError (kTooFewPoints, kNonFinite; kDegenerate when no sample gives a shape
/// or too few points stay within the threshold: no answer). The least-squares fit of the
/// inliers follows RobustOptions::least_squares: by default a fit that does not converge throws
/// kNotConverged; with require_convergence off it is returned with fit.stats.converged = false
/// (an expected numerical outcome is a result, docs/DEVELOPING.md). Samples that give no
/// shape or do not converge are skipped, never reported.

#include "mlp/geometry/fit.h"
#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <cstdint>
#include <vector>

namespace mlp::geometry {

struct RobustOptions {
  /// Inlier threshold on |orthogonal distance| [mm]; 0 = automatic: 2.5 robust sigma, with
  /// sigma = 1.4826 * median |residual| (Rousseeuw & Leroy), re-estimated while trimming.
  double inlier_threshold_mm = 0.0;
  int max_samples = 2000;     ///< upper bound on consensus samples
  double confidence = 0.999;  ///< MSAC stops adaptively at this probability of a clean sample
  uint64_t random_seed = 42;  ///< fixed seed: same cloud, same answer
  int max_refinements = 20;
  /// The least-squares fits of the inliers (iterations, require_convergence). The minimal
  /// samples are fitted with the defaults.
  FitOptions least_squares;
  void Check() const;
};

template <class Shape>
struct RobustFitResult {
  FitResult<Shape> fit;       ///< least-squares fit of the inliers
  std::vector<int> inliers;   ///< indices into the input
  double threshold_mm = 0.0;  ///< threshold finally used
  int samples = 0;            ///< consensus samples drawn
  /// The inlier set stopped changing within RobustOptions::max_refinements. False: it still
  /// changed in the last refinement (points at the threshold going in and out); `fit` and
  /// `inliers` are the last set's, which agree with each other.
  bool inliers_settled = false;
  /// Both: the inliers settled and their least-squares fit converged (fit.stats.converged).
  bool Converged() const { return inliers_settled && fit.stats.converged; }
};

/// The middle value of `values` (the upper of the two middle ones for an even count), as the
/// robust fits take their medians; NaN for none.
double Median(std::vector<double> values);

RobustFitResult<Line3> FitLine3Robust(const Points3& points, const RobustOptions& options = {});
RobustFitResult<Plane> FitPlaneRobust(const Points3& points, const RobustOptions& options = {});
RobustFitResult<Circle3> FitCircle3Robust(const Points3& points, const RobustOptions& options = {});
RobustFitResult<Sphere> FitSphereRobust(const Points3& points, const RobustOptions& options = {});
RobustFitResult<Cylinder> FitCylinderRobust(const Points3& points,
                                            const RobustOptions& options = {});
RobustFitResult<Cone> FitConeRobust(const Points3& points, const RobustOptions& options = {});
RobustFitResult<Ellipse3> FitEllipse3Robust(const Points3& points,
                                            const RobustOptions& options = {});

}  // namespace mlp::geometry
