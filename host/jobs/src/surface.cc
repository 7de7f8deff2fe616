#include "mlp/jobs/surface.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <flann/flann.hpp>

namespace mlp::jobs {
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

}  // namespace

SurfaceMeasurement MeasureSurface(const geometry::Points3& points, const SurfaceNominal& n) {
  CheckNominal(n);
  // An exact k-d tree nearest-neighbour search (FLANN, one tree, unlimited checks): the nominal
  // is a few thousand points, the cloud tens of thousands.
  const auto nominal_count = static_cast<size_t>(n.points_mcs.cols());
  flann::Matrix<double> data(const_cast<double*>(n.points_mcs.data()), nominal_count, 3);
  flann::Index<flann::L2_Simple<double>> index(data, flann::KDTreeSingleIndexParams(10));
  index.buildIndex();
  const auto count = static_cast<size_t>(points.cols());
  std::vector<int> nearest(count);
  std::vector<double> dist2(count);
  flann::Matrix<double> queries(const_cast<double*>(points.data()), count, 3);
  flann::Matrix<int> nearest_m(nearest.data(), count, 1);
  flann::Matrix<double> dist2_m(dist2.data(), count, 1);
  flann::SearchParams params(flann::FLANN_CHECKS_UNLIMITED);
  params.cores = 1;
  index.knnSearch(queries, nearest_m, dist2_m, 1, params);

  SurfaceMeasurement m;
  std::vector<char> seen(nominal_count, 0);
  std::vector<Eigen::Index> used;
  for (size_t i = 0; i < count; ++i) {
    const auto k = static_cast<Eigen::Index>(nearest[i]);
    const Vec3 d = points.col(static_cast<Eigen::Index>(i)) - n.points_mcs.col(k);
    const double along = d.dot(n.normals_mcs.col(k));
    // Beyond the band: another surface. Farther across than a spacing from the nearest nominal
    // point: past the patch's edge.
    if (std::abs(along) > n.band_mm || (d - along * n.normals_mcs.col(k)).norm() > n.spacing_mm)
      continue;
    m.deviation_mm.push_back(along);
    used.push_back(static_cast<Eigen::Index>(i));
    seen[static_cast<size_t>(k)] = 1;
  }
  if (static_cast<int>(used.size()) < kMinPoints)
    throw FeatureError("surface: " + std::to_string(used.size()) +
                       " points on the nominal patch, at least " + std::to_string(kMinPoints) +
                       " needed");
  m.points_mcs.resize(3, static_cast<Eigen::Index>(used.size()));
  for (size_t j = 0; j < used.size(); ++j)
    m.points_mcs.col(static_cast<Eigen::Index>(j)) = points.col(used[j]);
  Summarise(&m);
  const auto hit = static_cast<double>(std::count(seen.begin(), seen.end(), 1));
  m.coverage = hit / static_cast<double>(nominal_count);
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

}  // namespace mlp::jobs
