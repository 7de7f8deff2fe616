#pragma once
// Helpers shared by the fits: input checks, moments, bases, residual statistics.

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit_result.h"
#include "mlp/geometry/types.h"

#include <cmath>
#include <string>
#include <vector>

#include "kernels.h"
#include <Eigen/Eigenvalues>

namespace mlp::geometry::internal {

/// Throws kTooFewPoints, and kNonFinite if `check_finite`. Fits that start from ComputeMoments
/// pass check_finite = false: NaN and infinity propagate into the moments, which are checked
/// there, saving a pass over the points.
template <class Derived>
void CheckPoints(const Eigen::MatrixBase<Derived>& points,
                 int min_points,
                 const char* shape,
                 bool check_finite = true) {
  if (points.cols() < min_points) {
    throw GeometryError(ErrorCode::kTooFewPoints, std::string(shape) + " needs at least " +
                                                      std::to_string(min_points) + " points, got " +
                                                      std::to_string(points.cols()));
  }
  if (check_finite && !points.allFinite()) {
    throw GeometryError(ErrorCode::kNonFinite,
                        std::string(shape) + ": input contains NaN or infinite coordinates");
  }
}

template <int N>
struct Moments {
  Eigen::Matrix<double, N, 1> centroid;
  Eigen::Matrix<double, N, N> scatter;  // sum (p - centroid)(p - centroid)^T
};

/// Centroid and scatter from sums of points shifted by the first point, so that data far from
/// the origin keeps its precision (the shifted one-pass formula loses only
/// |mean - first|^2 / extent^2 digits). Throws kNonFinite if any coordinate is NaN or infinite
/// (inf - inf is NaN: either ends up in the sums).
template <int N>
Moments<N> MomentsFromSums(const Eigen::Matrix<double, N, 1>& shift,
                           const Eigen::Matrix<double, N, 1>& sum,
                           const double (&outer)[N][N],
                           Eigen::Index n) {
  if (!sum.allFinite() || !shift.allFinite()) {
    throw GeometryError(ErrorCode::kNonFinite, "input contains NaN or infinite coordinates");
  }
  const Eigen::Matrix<double, N, 1> mean_q = sum / static_cast<double>(n);
  Moments<N> m;
  m.centroid = shift + mean_q;
  for (int a = 0; a < N; ++a) {
    for (int b = 0; b <= a; ++b) {
      m.scatter(a, b) = m.scatter(b, a) =
          outer[a][b] - static_cast<double>(n) * mean_q(a) * mean_q(b);
    }
  }
  return m;
}

/// Moments of 3D points from the vectorised kernel's sums.
inline Moments<3> MomentsFromSums(const Vec3& shift, const PointSums3& s, Eigen::Index n) {
  const double outer[3][3] = {{s.outer[0], s.outer[1], s.outer[2]},
                              {s.outer[1], s.outer[3], s.outer[4]},
                              {s.outer[2], s.outer[4], s.outer[5]}};
  return MomentsFromSums<3>(shift, Vec3(s.sum[0], s.sum[1], s.sum[2]), outer, n);
}

/// One pass over the points (the vectorised kernel for 3D).
template <int N>
Moments<N> ComputeMoments(const Eigen::Matrix<double, N, Eigen::Dynamic>& points) {
  using VecN = Eigen::Matrix<double, N, 1>;
  const VecN shift = points.col(0);
  if constexpr (N == 3) {
    return MomentsFromSums(shift, SumShiftedPoints(points.data(), points.cols(), shift.data()),
                           points.cols());
  } else {
    VecN sum = VecN::Zero();
    double outer[N][N] = {};
    for (Eigen::Index i = 0; i < points.cols(); ++i) {
      const VecN q = points.col(i) - shift;
      sum += q;
#pragma GCC unroll 4
      for (int a = 0; a < N; ++a) {
#pragma GCC unroll 4
        for (int b = 0; b <= a; ++b) outer[a][b] += q(a) * q(b);
      }
    }
    return MomentsFromSums<N>(shift, sum, outer, points.cols());
  }
}

/// Statistics of residuals given as a vector (vectorised passes for the closed-form fits).
inline FitStats StatsOf(const Eigen::VectorXd& r, int iterations) {
  FitStats s;
  s.n = static_cast<int>(r.size());
  s.rms = std::sqrt(r.squaredNorm() / static_cast<double>(r.size()));
  s.min_residual = r.minCoeff();
  s.max_residual = r.maxCoeff();
  s.iterations = iterations;
  return s;
}

/// Unit vectors u, v with u x v = axis (deterministic for a given axis).
void OrthonormalBasis(const Vec3& axis, Vec3* u, Vec3* v);

/// Points minus `origin`, expressed in the basis (u, v, w) as 3 x N.
Points3 ToFrame(
    const Points3& points, const Vec3& origin, const Vec3& u, const Vec3& v, const Vec3& w);

/// Residual statistics from a residual function r(i), i in [0, n).
template <class F>
FitStats ComputeStats(Eigen::Index n, F residual, int iterations) {
  FitStats s;
  s.n = static_cast<int>(n);
  s.iterations = iterations;
  double ss = 0.0;
  s.min_residual = INFINITY;
  s.max_residual = -INFINITY;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double r = residual(i);
    ss += r * r;
    s.min_residual = std::min(s.min_residual, r);
    s.max_residual = std::max(s.max_residual, r);
  }
  s.rms = std::sqrt(ss / static_cast<double>(n));
  return s;
}

/// Evenly strided subsample of at most `max_count` columns (all of them if fewer).
template <int N>
Eigen::Matrix<double, N, Eigen::Dynamic> Subsample(
    const Eigen::Matrix<double, N, Eigen::Dynamic>& points, Eigen::Index max_count) {
  const Eigen::Index n = points.cols();
  if (n <= max_count) return points;
  Eigen::Matrix<double, N, Eigen::Dynamic> out(N, max_count);
  for (Eigen::Index k = 0; k < max_count; ++k) out.col(k) = points.col(k * n / max_count);
  return out;
}

/// Subsample as above, but without a copy when every point is kept: returns `points` itself,
/// or the subsample stored in `storage`.
template <int N>
const Eigen::Matrix<double, N, Eigen::Dynamic>& SubsampleView(
    const Eigen::Matrix<double, N, Eigen::Dynamic>& points,
    Eigen::Index max_count,
    Eigen::Matrix<double, N, Eigen::Dynamic>* storage) {
  if (points.cols() <= max_count) return points;
  *storage = Subsample<N>(points, max_count);
  return *storage;
}

/// RMS distance of centred points from their centroid: the length scale of the data [mm].
template <int N>
double DataScale(const Moments<N>& m, Eigen::Index n) {
  return std::sqrt(m.scatter.trace() / static_cast<double>(n));
}

/// Eigen-decomposition of a scatter matrix, ascending eigenvalues.
template <int N>
Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>> SortedEigen(
    const Eigen::Matrix<double, N, N>& scatter) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, N, N>>(scatter);
}

/// Flips `v` so that its largest-magnitude component is positive (a stable sign convention).
template <class V>
V CanonicalSign(const V& v) {
  Eigen::Index k = 0;
  v.cwiseAbs().maxCoeff(&k);
  return v(k) < 0 ? V(-v) : v;
}

/// Least-squares plane from precomputed moments, without residual statistics (used by the
/// two-stage circle and ellipse fits, which report in-plane residuals instead).
FitResult<Plane> PlaneFromMoments(const Moments<3>& m, Eigen::Index count);
/// In-plane coordinates (along the plane's covariance u, v) of the points.
Points2 ProjectOnPlane(const Points3& points, const FitResult<Plane>& plane);

/// Covariance of a two-stage fit (plane, then a shape in it): block-diagonal, since the stages
/// are estimated independently. The in-plane parameters keep their names except the first ones,
/// which are renamed (e.g. center_x -> center_u) because they are along the plane's u, v.
Covariance TwoStageCovariance(const FitResult<Plane>& plane,
                              const Covariance& in_plane,
                              const std::vector<std::string>& renamed_first);

[[noreturn]] void ThrowDegenerate(const std::string& shape, const std::string& why);
/// A numerically singular J^T J: "not determined" with an unbounded standard deviation where
/// FitOptions' test applies (`judged`), plain "not separable" for reference computations.
[[noreturn]] void ThrowNotSeparable(const std::string& shape, bool judged);

/// The angle [deg] that angles (rad, any order, any range) cover: 360 less the largest gap
/// between neighbours around the circle. Sorts `angles_rad`.
double CoveredAngleDeg(std::vector<double>& angles_rad);

/// Throws kDegenerate "<shape>: not determined: the points cover X deg about the fitted
/// <about>; below <min_deg> deg <why>" when `covered_deg` is under `min_deg`.
void RequireCoverage(const std::string& shape,
                     double covered_deg,
                     double min_deg,
                     const std::string& about,
                     const std::string& why);

/// FitOptions::max_relative_std_dev applied: throws kDegenerate, naming the first of
/// `parameters` (names in `c`) whose standard deviation exceeds `max_relative` x `radius`.
void RequireDetermined(const std::string& shape,
                       const Covariance& c,
                       const std::vector<std::string>& parameters,
                       double radius,
                       double max_relative);
[[noreturn]] void ThrowNotConverged(const std::string& shape, int iterations);

}  // namespace mlp::geometry::internal
