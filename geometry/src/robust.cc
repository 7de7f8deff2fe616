#include "mlp/geometry/robust.h"

#include "mlp/geometry/fit.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "common.h"

namespace mlp::geometry {
namespace {

constexpr Eigen::Index kScoreSubset = 4000;  // points used to score a consensus sample

template <class Shape>
using LsFit = std::function<FitResult<Shape>(const Points3&, const FitOptions&)>;

Points3 Select(const Points3& points, const std::vector<int>& idx) {
  Points3 out(3, static_cast<Eigen::Index>(idx.size()));
  for (size_t k = 0; k < idx.size(); ++k)
    out.col(static_cast<Eigen::Index>(k)) = points.col(idx[k]);
  return out;
}

template <class Shape>
Eigen::VectorXd AbsDistances(const Shape& s, const Points3& points) {
  Eigen::VectorXd d(points.cols());
  for (Eigen::Index i = 0; i < points.cols(); ++i)
    d(i) = std::abs(SignedDistance(s, points.col(i)));
  return d;
}

double Median(Eigen::VectorXd v) {
  auto mid = v.begin() + v.size() / 2;
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Robust sigma from the median absolute residual with the small-sample correction.
double RobustSigma(const Eigen::VectorXd& abs_d, int sample_size) {
  const double n = static_cast<double>(abs_d.size());
  return 1.4826 * (1.0 + 5.0 / std::max(1.0, n - sample_size)) * Median(abs_d);
}

template <class Shape>
struct Consensus {
  Shape shape;
  int samples = 0;
};

// MSAC (threshold given) or LMedS (threshold 0) over random minimal samples.
template <class Shape>
Consensus<Shape> FindConsensus(const Points3& points,
                               int sample_size,
                               const LsFit<Shape>& fit,
                               const RobustOptions& opt) {
  std::mt19937_64 rng(opt.random_seed);
  const Eigen::Index n = points.cols();
  std::uniform_int_distribution<Eigen::Index> pick(0, n - 1);
  std::vector<int> score_idx(static_cast<size_t>(std::min(n, kScoreSubset)));
  for (size_t k = 0; k < score_idx.size(); ++k) {
    score_idx[k] = static_cast<int>(n <= kScoreSubset ? static_cast<Eigen::Index>(k) : pick(rng));
  }
  const Points3 scored = Select(points, score_idx);
  const double t2 = opt.inlier_threshold_mm * opt.inlier_threshold_mm;
  Consensus<Shape> best;
  double best_cost = INFINITY;
  int needed = opt.max_samples;
  bool found = false;
  std::vector<int> sample(static_cast<size_t>(sample_size));
  // A minimal sample determines its shape exactly or not at all: the determinacy test on the
  // covariance (FitOptions::max_relative_std_dev) is for the final fit of the inliers. On a
  // cone's narrow sector it refused every sample ("no sample gave a shape") where the final
  // fit would have said why.
  FitOptions sample_options;
  sample_options.max_relative_std_dev = std::numeric_limits<double>::infinity();
  for (int s = 0; s < needed && s < opt.max_samples; ++s) {
    best.samples = s + 1;
    for (int& i : sample) i = static_cast<int>(pick(rng));
    FitResult<Shape> candidate;
    try {
      candidate = fit(Select(points, sample), sample_options);
    } catch (const GeometryError&) {
      continue;  // degenerate sample (repeated or collinear points): draw another
    }
    const Eigen::VectorXd d = AbsDistances(candidate.shape, scored);
    double cost = 0.0;
    if (t2 > 0.0) {
      cost = d.array().square().min(t2).sum();
    } else {
      cost = Median(d);
    }
    if (cost < best_cost) {
      best_cost = cost, best.shape = candidate.shape, found = true;
      if (t2 > 0.0) {  // adaptive number of samples from the inlier ratio
        const double w = (d.array() <= opt.inlier_threshold_mm).cast<double>().mean();
        const double p_clean = std::pow(w, sample_size);
        if (p_clean > 1e-12) {
          needed = static_cast<int>(std::ceil(std::log(1.0 - opt.confidence) /
                                              std::log1p(-std::min(p_clean, 1.0 - 1e-12))));
        }
      }
    }
  }
  if (!found) throw GeometryError(ErrorCode::kDegenerate, "robust fit: no sample gave a shape");
  return best;
}

std::vector<int> Within(const Eigen::VectorXd& abs_d, double threshold) {
  std::vector<int> idx;
  for (Eigen::Index i = 0; i < abs_d.size(); ++i) {
    if (abs_d(i) <= threshold) idx.push_back(static_cast<int>(i));
  }
  return idx;
}

template <class Shape>
RobustFitResult<Shape> FitRobust(const Points3& points,
                                 int sample_size,
                                 int min_points,
                                 const LsFit<Shape>& fit,
                                 const RobustOptions& opt) {
  opt.Check();
  internal::CheckPoints(points, min_points, "robust fit");
  const auto consensus = FindConsensus<Shape>(points, sample_size, fit, opt);
  RobustFitResult<Shape> result;
  result.samples = consensus.samples;
  Shape shape = consensus.shape;
  const bool automatic = opt.inlier_threshold_mm <= 0.0;
  std::vector<int> inliers;
  for (int it = 0; it < opt.max_refinements; ++it) {
    const Eigen::VectorXd d = AbsDistances(shape, points);
    double threshold = opt.inlier_threshold_mm;
    if (automatic) {
      // Scale from the current model's residuals; floor at rounding so exact data keeps all.
      const double scale = std::sqrt(points.squaredNorm() / static_cast<double>(points.cols()));
      threshold = std::max(2.5 * RobustSigma(d, sample_size), 1e-12 * (1.0 + scale));
    }
    std::vector<int> next = Within(d, threshold);
    if (static_cast<int>(next.size()) < min_points) {
      throw GeometryError(ErrorCode::kDegenerate,
                          "robust fit: too few inliers (" + std::to_string(next.size()) + ")");
    }
    result.threshold_mm = threshold;
    if (next == inliers) {
      result.inliers_settled = true;
      break;
    }
    inliers = std::move(next);
    result.fit = fit(Select(points, inliers), opt.least_squares);
    shape = result.fit.shape;
  }
  result.inliers = std::move(inliers);
  return result;
}

}  // namespace

void RobustOptions::Check() const {
  if (!(inlier_threshold_mm >= 0.0) || !std::isfinite(inlier_threshold_mm) || max_samples < 1 ||
      !(confidence > 0.0 && confidence < 1.0) || max_refinements < 1) {
    throw GeometryError(ErrorCode::kInvalidArgument,
                        "RobustOptions: threshold >= 0, max_samples >= 1, 0 < confidence < 1");
  }
  least_squares.Check();
}

RobustFitResult<Line3> FitLine3Robust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Line3>(
      p, 2, 2, [](const Points3& s, const FitOptions&) { return FitLine3(s); }, o);
}
RobustFitResult<Plane> FitPlaneRobust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Plane>(
      p, 3, 3, [](const Points3& s, const FitOptions&) { return FitPlane(s); }, o);
}
RobustFitResult<Circle3> FitCircle3Robust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Circle3>(
      p, 3, 3, [](const Points3& s, const FitOptions& f) { return FitCircle3(s, f); }, o);
}
RobustFitResult<Sphere> FitSphereRobust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Sphere>(
      p, 4, 4, [](const Points3& s, const FitOptions& f) { return FitSphere(s, f); }, o);
}
RobustFitResult<Cylinder> FitCylinderRobust(const Points3& p, const RobustOptions& o) {
  // Seven points: five determine a cylinder only up to several solutions; two more pick one.
  return FitRobust<Cylinder>(
      p, 7, 7, [](const Points3& s, const FitOptions& f) { return FitCylinder(s, f); }, o);
}
RobustFitResult<Cone> FitConeRobust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Cone>(
      p, 8, 8, [](const Points3& s, const FitOptions& f) { return FitCone(s, f); }, o);
}
RobustFitResult<Ellipse3> FitEllipse3Robust(const Points3& p, const RobustOptions& o) {
  return FitRobust<Ellipse3>(
      p, 6, 6, [](const Points3& s, const FitOptions& f) { return FitEllipse3(s, f); }, o);
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  const auto mid = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

}  // namespace mlp::geometry
