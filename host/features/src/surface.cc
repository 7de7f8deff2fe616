#include "mlp/features/surface.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <utility>

#include <Eigen/Eigenvalues>
#include <flann/flann.hpp>

namespace mlp::features {
namespace {

using geometry::Vec3;
constexpr int kMinPoints = 50;

void CheckNominal(const SurfaceNominal& n) {
  if (n.points_mcs.cols() < 3 || n.normals_mcs.cols() != n.points_mcs.cols())
    throw FeatureError("surface: the nominal needs 3 or more points, each with a normal");
  if (!(n.spacing_mm > 0) || !(n.band_mm > 0))
    throw FeatureError("surface: the nominal spacing and band must be > 0");
  if (!n.points_mcs.allFinite() || !n.normals_mcs.allFinite())
    throw FeatureError("surface: the nominal holds a number that is not finite");
  for (Eigen::Index i = 0; i < n.normals_mcs.cols(); ++i)
    if (std::abs(n.normals_mcs.col(i).norm() - 1) > 1e-3)
      throw FeatureError("surface: nominal normal " + std::to_string(i + 1) +
                         " is not a unit vector");
}

void Summarise(SurfaceMeasurement* m) {
  const auto& d = m->deviation_mm;
  double sum = 0, sum2 = 0, worst = 0;
  m->min_mm = *std::min_element(d.begin(), d.end());
  m->max_mm = *std::max_element(d.begin(), d.end());
  for (double v : d) sum += v, sum2 += v * v, worst = std::max(worst, std::abs(v));
  m->points = static_cast<int>(d.size());
  m->mean_mm = sum / static_cast<double>(d.size());
  m->rms_mm = std::sqrt(sum2 / static_cast<double>(d.size()));
  m->profile_mm = 2 * worst;
}

// The nominal's points in an exact k-d tree (FLANN, one tree, unlimited checks): the nominal is
// a few thousand points, the cloud tens of thousands.
class NominalIndex {
 public:
  explicit NominalIndex(const SurfaceNominal& n)
      : data_(
            const_cast<double*>(n.points_mcs.data()), static_cast<size_t>(n.points_mcs.cols()), 3),
        index_(data_, flann::KDTreeSingleIndexParams(10)) {
    index_.buildIndex();
  }
  std::vector<int> Nearest(const geometry::Points3& points) {
    const auto count = static_cast<size_t>(points.cols());
    std::vector<int> nearest(count);
    std::vector<double> dist2(count);
    flann::Matrix<double> queries(const_cast<double*>(points.data()), count, 3);
    flann::Matrix<int> nearest_m(nearest.data(), count, 1);
    flann::Matrix<double> dist2_m(dist2.data(), count, 1);
    flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
    params.cores = 1;
    index_.knnSearch(queries, nearest_m, dist2_m, 1, params);
    return nearest;
  }

 private:
  flann::Matrix<double> data_;
  flann::Index<flann::L2_Simple<double>> index_;
};

// A point on the patch: its nominal point and its deviation along that point's normal.
struct OnPatch {
  Eigen::Index point = 0, nominal = 0;
  double along = 0.0;
};

// The points on the patch: within the band along the nearest nominal point's normal (beyond:
// another surface), and within a spacing across it (beyond: past the patch's edge).
std::vector<OnPatch> Associate(const geometry::Points3& points,
                               const SurfaceNominal& n,
                               NominalIndex& index) {
  const std::vector<int> nearest = index.Nearest(points);
  std::vector<OnPatch> out;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const auto k = static_cast<Eigen::Index>(nearest[static_cast<size_t>(i)]);
    const Vec3 d = points.col(i) - n.points_mcs.col(k);
    const double along = d.dot(n.normals_mcs.col(k));
    if (std::abs(along) > n.band_mm || (d - along * n.normals_mcs.col(k)).norm() > n.spacing_mm)
      continue;
    out.push_back({i, k, along});
  }
  return out;
}

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

std::string DescribeMotion(const Vec6& v, double lever_mm) {
  const Vec3 rot = v.head<3>(), trans = v.tail<3>();
  const bool turning = rot.norm() * lever_mm > trans.norm();
  const Vec3 axis = (turning ? rot : trans).normalized();
  std::ostringstream os;
  os.precision(3);
  os << (turning ? "rotation about (" : "translation along (") << axis.x() << ", " << axis.y()
     << ", " << axis.z() << "): the patch slides along it";
  return os.str();
}

// Point-to-plane ICP (Chen & Medioni 1992): each step the linearised least-squares motion of
// the points on the patch against their nominal points' tangent planes, re-associated after
// every step. Rotations are scaled by the patch's radius so the step is in mm throughout;
// directions the patch does not fix (an eigenvalue under 1e-8 of the largest) are left out
// and reported. `on`: the points' association as given (it starts the first step). Moves
// `points` and returns the motion.
SurfaceBestFit BestFit(geometry::Points3* points,
                       const SurfaceNominal& n,
                       NominalIndex& index,
                       std::vector<OnPatch> on) {
  SurfaceBestFit fit;
  fit.about_mcs = points->rowwise().mean();
  const Vec3& c = fit.about_mcs;
  const double lever =
      std::max(std::sqrt((points->colwise() - c).colwise().squaredNorm().mean()), 1e-3);
  Eigen::Matrix3d r_total = Eigen::Matrix3d::Identity();
  Vec3 t_total = Vec3::Zero();
  for (int it = 0; it < 50; ++it) {
    if (it > 0) on = Associate(*points, n, index);
    if (static_cast<int>(on.size()) < kMinPoints) break;
    Mat6 jtj = Mat6::Zero();
    Vec6 jtr = Vec6::Zero();
    for (const OnPatch& q : on) {
      const Vec3 normal = n.normals_mcs.col(q.nominal);
      Vec6 j;
      j.head<3>() = (points->col(q.point) - c).cross(normal) / lever;  // per mm of arc
      j.tail<3>() = normal;
      jtj += j * j.transpose();
      jtr += j * q.along;
    }
    const Eigen::SelfAdjointEigenSolver<Mat6> es(jtj);
    Vec6 step = Vec6::Zero();
    const double largest = es.eigenvalues()(5);
    for (int k = 0; k < 6; ++k) {
      const Vec6 v = es.eigenvectors().col(k);
      if (es.eigenvalues()(k) > 1e-8 * largest) {
        step -= v * (v.dot(jtr) / es.eigenvalues()(k));
      } else if (it == 0) {
        Vec6 motion = v;
        motion.head<3>() /= lever;
        fit.not_determined.push_back(DescribeMotion(motion, lever));
      }
    }
    const Vec3 w = step.head<3>() / lever, t = step.tail<3>();
    const Eigen::Matrix3d r = w.norm() > 0
                                  ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                                  : Eigen::Matrix3d::Identity();
    *points = (r * (points->colwise() - c)).colwise() + (c + t);
    r_total = r * r_total, t_total = r * t_total + t;
    fit.iterations = it + 1;
    if (step.norm() < 1e-7) {  // 0.1 nm: the fit moves nothing more
      fit.converged = true;
      break;
    }
  }
  const Eigen::AngleAxisd aa(r_total);
  fit.rotation_rad = aa.axis() * aa.angle();
  fit.translation_mm = t_total;
  return fit;
}

}  // namespace

SurfaceMeasurement MeasureSurface(const geometry::Points3& points, const SurfaceNominal& n) {
  CheckNominal(n);
  NominalIndex index(n);
  geometry::Points3 moved;
  const geometry::Points3* measured = &points;
  SurfaceMeasurement m;
  if (n.best_fit) {
    // The fit starts from the points on the patch as placed; the rest stay where they are.
    std::vector<OnPatch> on = Associate(points, n, index);
    if (static_cast<int>(on.size()) < kMinPoints)
      throw FeatureError("surface: " + std::to_string(on.size()) +
                         " points on the nominal patch, at least " + std::to_string(kMinPoints) +
                         " needed");
    moved.resize(3, static_cast<Eigen::Index>(on.size()));
    for (size_t j = 0; j < on.size(); ++j) {
      moved.col(static_cast<Eigen::Index>(j)) = points.col(on[j].point);
      on[j].point = static_cast<Eigen::Index>(j);  // now an index into `moved`
    }
    m.best_fit = BestFit(&moved, n, index, std::move(on));
    measured = &moved;
  }
  const std::vector<OnPatch> on = Associate(*measured, n, index);
  if (static_cast<int>(on.size()) < kMinPoints)
    throw FeatureError("surface: " + std::to_string(on.size()) +
                       " points on the nominal patch, at least " + std::to_string(kMinPoints) +
                       " needed");
  std::vector<char> seen(static_cast<size_t>(n.points_mcs.cols()), 0);
  m.points_mcs.resize(3, static_cast<Eigen::Index>(on.size()));
  for (size_t j = 0; j < on.size(); ++j) {
    m.deviation_mm.push_back(on[j].along);
    m.points_mcs.col(static_cast<Eigen::Index>(j)) = measured->col(on[j].point);
    seen[static_cast<size_t>(on[j].nominal)] = 1;
  }
  Summarise(&m);
  const auto hit = static_cast<double>(std::count(seen.begin(), seen.end(), 1));
  m.coverage = hit / static_cast<double>(n.points_mcs.cols());
  m.area_mm2 = hit * n.spacing_mm * n.spacing_mm;
  return m;
}

SurfaceNominal ParseVectorPoints(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  std::vector<double> values;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    double v[6];
    std::string extra;
    for (double& x : v)
      if (!(fields >> x) || !std::isfinite(x))
        throw FeatureError("vector points: line " + std::to_string(line_no) +
                           " must hold x y z i j k (6 numbers)");
    if (fields >> extra)
      throw FeatureError("vector points: line " + std::to_string(line_no) +
                         " holds more than x y z i j k");
    values.insert(values.end(), v, v + 6);
  }
  SurfaceNominal n;
  const auto count = static_cast<Eigen::Index>(values.size() / 6);
  n.points_mcs.resize(3, count), n.normals_mcs.resize(3, count);
  for (Eigen::Index i = 0; i < count; ++i) {
    const double* v = &values[static_cast<size_t>(i) * 6];
    n.points_mcs.col(i) = Vec3(v[0], v[1], v[2]);
    n.normals_mcs.col(i) = Vec3(v[3], v[4], v[5]);
  }
  return n;
}

}  // namespace mlp::features
