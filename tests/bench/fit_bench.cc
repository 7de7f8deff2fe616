// Speed and accuracy of every fit at 1e3, 1e5 and 1e6 points, against PCL's sample-consensus
// segmentation with coefficient optimisation on the same data, and a memory-read baseline, all
// in one run. Accuracy is reported as counters (errors against the generating truth, in um and
// urad). Run: build/bin/mlp_fit_bench --benchmark_counters_tabular=true
//
// Data: 2 um Gaussian noise along the surface normal, full features (sphere: a hemisphere),
// about 100 mm from the origin (PCL stores float coordinates: 8 nm resolution there).

#include "mlp/geometry/chebyshev.h"
#include "mlp/geometry/fit.h"

#include <map>
#include <random>

#include <benchmark/benchmark.h>
#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/segmentation/sac_segmentation.h>

namespace {

using namespace mlp::geometry;

constexpr double kNoiseMm = 0.002;
constexpr double kPclThresholdMm = 4 * kNoiseMm;
const Vec3 kCenter(100.0, 50.0, -20.0);
const Vec3 kAxis = Vec3(0.2, -0.1, 1.0).normalized();
constexpr double kRadius = 12.7;

struct Data {
  Points3 points;
  Points3 normals;  // true surface normals (given to PCL's cylinder model)
};

Vec3 U() { return kAxis.unitOrthogonal(); }
Vec3 V() { return kAxis.cross(U()); }

// Points on the named shape: plane (normal kAxis through kCenter, 100 x 100 mm), sphere
// (hemisphere around kAxis), circle (in the plane normal to kAxis), cylinder (length 40 mm).
Data Make(const std::string& shape, int n) {
  std::mt19937_64 rng(12345u + n);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, kNoiseMm);
  Data d{Points3(3, n), Points3(3, n)};
  for (int i = 0; i < n; ++i) {
    const double t = 2 * M_PI * uni(rng);
    const Vec3 radial = std::cos(t) * U() + std::sin(t) * V();
    Vec3 p, nrm;
    if (shape == "plane") {
      const double v = uni(rng);  // one draw per statement, in the order GCC took them
      const double u = uni(rng);
      p = kCenter + 100 * (u - 0.5) * U() + 100 * (v - 0.5) * V();
      nrm = kAxis;
    } else if (shape == "sphere") {
      const double polar = std::acos(uni(rng));
      nrm = std::cos(polar) * kAxis + std::sin(polar) * radial;
      p = kCenter + kRadius * nrm;
    } else if (shape == "circle") {
      nrm = radial;
      p = kCenter + kRadius * radial;
    } else {  // cylinder
      nrm = radial;
      p = kCenter + 40 * (uni(rng) - 0.5) * kAxis + kRadius * radial;
    }
    d.points.col(i) = p + noise(rng) * nrm;
    d.normals.col(i) = nrm;
  }
  return d;
}

const Data& Cached(const std::string& shape, int n) {
  static std::map<std::pair<std::string, int>, Data> cache;
  auto key = std::make_pair(shape, n);
  auto it = cache.find(key);
  if (it == cache.end()) it = cache.emplace(key, Make(shape, n)).first;
  return it->second;
}

double AngleUrad(const Vec3& a, const Vec3& b) {
  return 1e6 * std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

// ---- mlprobe ----

void BM_MlpPlane(benchmark::State& state) {
  const auto& d = Cached("plane", static_cast<int>(state.range(0)));
  FitResult<Plane> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitPlane(d.points));
  state.counters["dir_err_urad"] = AngleUrad(fit.shape.normal, kAxis);
  state.counters["pos_err_um"] = 1e3 * std::abs(SignedDistance(fit.shape, kCenter));
}

void BM_MlpSphere(benchmark::State& state) {
  const auto& d = Cached("sphere", static_cast<int>(state.range(0)));
  FitResult<Sphere> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitSphere(d.points));
  state.counters["pos_err_um"] = 1e3 * (fit.shape.center - kCenter).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(fit.shape.radius - kRadius);
}

void BM_MlpCircle(benchmark::State& state) {
  const auto& d = Cached("circle", static_cast<int>(state.range(0)));
  FitResult<Circle3> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitCircle3(d.points));
  state.counters["pos_err_um"] = 1e3 * (fit.shape.center - kCenter).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(fit.shape.radius - kRadius);
  state.counters["dir_err_urad"] = AngleUrad(fit.shape.normal, kAxis);
}

// The same circle by NIST's definition (plane first, then the circle): the spatial one above
// (ISO 10360-6, the default) starts from it.
void BM_MlpCirclePlaneFirst(benchmark::State& state) {
  const auto& d = Cached("circle", static_cast<int>(state.range(0)));
  FitOptions options;
  options.circle3 = Circle3Definition::kPlaneThenCircle;
  FitResult<Circle3> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitCircle3(d.points, options));
  state.counters["pos_err_um"] = 1e3 * (fit.shape.center - kCenter).norm();
  state.counters["dir_err_urad"] = AngleUrad(fit.shape.normal, kAxis);
}

void BM_MlpCylinder(benchmark::State& state) {
  const auto& d = Cached("cylinder", static_cast<int>(state.range(0)));
  FitResult<Cylinder> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitCylinder(d.points));
  state.counters["pos_err_um"] = 1e3 * (kCenter - fit.shape.point).cross(fit.shape.axis).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(fit.shape.radius - kRadius);
  state.counters["dir_err_urad"] = AngleUrad(fit.shape.axis, kAxis);
}

void BM_MlpLine(benchmark::State& state) {
  auto d = Cached("cylinder",
                  static_cast<int>(state.range(0)));  // the axis direction spread: a thick line
  FitResult<Line3> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitLine3(d.points));
}

void BM_MlpCone(benchmark::State& state) {
  // A cone of half-angle 20 deg around kAxis, 30 mm long.
  const int n = static_cast<int>(state.range(0));
  static std::map<int, Points3> cache;
  if (!cache.count(n)) {
    std::mt19937_64 rng(99u + n);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, kNoiseMm);
    Points3 p(3, n);
    const double psi = 20 * M_PI / 180;
    for (int i = 0; i < n; ++i) {
      const double t = 2 * M_PI * uni(rng), z = 30 * uni(rng) - 15;
      const Vec3 radial = std::cos(t) * U() + std::sin(t) * V();
      const Vec3 nrm = std::cos(psi) * radial - std::sin(psi) * kAxis;
      p.col(i) = kCenter + z * kAxis + (10 + z * std::tan(psi)) * radial + noise(rng) * nrm;
    }
    cache[n] = p;
  }
  FitResult<Cone> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitCone(cache[n]));
  state.counters["dir_err_urad"] = AngleUrad(fit.shape.axis, kAxis);
}

void BM_MlpEllipse(benchmark::State& state) {
  auto d = Cached("circle", static_cast<int>(state.range(0)));
  // Squash the circle into an ellipse (semi-axes 12.7 and 8.89 mm) in its plane.
  for (Eigen::Index i = 0; i < d.points.cols(); ++i) {
    const Vec3 q = d.points.col(i) - kCenter;
    d.points.col(i) = kCenter + q.dot(U()) * U() + 0.7 * q.dot(V()) * V() + q.dot(kAxis) * kAxis;
  }
  FitResult<Ellipse3> fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitEllipse3(d.points));
  state.counters["size_err_um"] = 1e3 * std::abs(fit.shape.semi_major - kRadius);
}

void BM_MlpFlatnessMinZone(benchmark::State& state) {
  const auto& d = Cached("plane", static_cast<int>(state.range(0)));
  MinZonePlaneFit fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitMinZonePlane(d.points));
}

void BM_MlpRoundnessMinZone(benchmark::State& state) {
  const auto& d = Cached("circle", static_cast<int>(state.range(0)));
  MinZoneCircleFit fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitMinZoneCircle(d.points));
}

void BM_MlpSphericityMinZone(benchmark::State& state) {
  const auto& d = Cached("sphere", static_cast<int>(state.range(0)));
  MinZoneSphereFit fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitMinZoneSphere(d.points));
}

void BM_MlpCylindricityMinZone(benchmark::State& state) {
  const auto& d = Cached("cylinder", static_cast<int>(state.range(0)));
  MinZoneCylinderFit fit;
  for (auto _ : state) benchmark::DoNotOptimize(fit = FitMinZoneCylinder(d.points));
}

// ---- PCL: SACSegmentation (RANSAC, threshold 4 sigma) + optimizeCoefficients ----

pcl::PointCloud<pcl::PointNormal>::Ptr ToPcl(const Data& d) {
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointNormal>>();
  cloud->resize(d.points.cols());
  for (Eigen::Index i = 0; i < d.points.cols(); ++i) {
    auto& p = (*cloud)[i];
    p.x = static_cast<float>(d.points(0, i)), p.y = static_cast<float>(d.points(1, i));
    p.z = static_cast<float>(d.points(2, i));
    p.normal_x = static_cast<float>(d.normals(0, i)),
    p.normal_y = static_cast<float>(d.normals(1, i));
    p.normal_z = static_cast<float>(d.normals(2, i));
  }
  return cloud;
}

template <class Seg>
pcl::ModelCoefficients RunPcl(benchmark::State& state, Seg& seg) {
  pcl::ModelCoefficients coeffs;
  pcl::PointIndices inliers;
  seg.setOptimizeCoefficients(true);
  seg.setMethodType(pcl::SAC_RANSAC);
  seg.setDistanceThreshold(kPclThresholdMm);
  seg.setMaxIterations(1000);
  for (auto _ : state) {
    seg.segment(inliers, coeffs);
    benchmark::DoNotOptimize(coeffs);
  }
  state.counters["inliers"] = static_cast<double>(inliers.indices.size());
  return coeffs;
}

void BM_PclPlane(benchmark::State& state) {
  const auto cloud = ToPcl(Cached("plane", static_cast<int>(state.range(0))));
  pcl::SACSegmentation<pcl::PointNormal> seg;
  seg.setModelType(pcl::SACMODEL_PLANE);
  seg.setInputCloud(cloud);
  const auto c = RunPcl(state, seg);
  const Vec3 n(c.values[0], c.values[1], c.values[2]);
  state.counters["dir_err_urad"] = AngleUrad(n, kAxis);
  state.counters["pos_err_um"] = 1e3 * std::abs(n.dot(kCenter) + c.values[3]) / n.norm();
}

void BM_PclSphere(benchmark::State& state) {
  const auto cloud = ToPcl(Cached("sphere", static_cast<int>(state.range(0))));
  pcl::SACSegmentation<pcl::PointNormal> seg;
  seg.setModelType(pcl::SACMODEL_SPHERE);
  seg.setInputCloud(cloud);
  const auto c = RunPcl(state, seg);
  state.counters["pos_err_um"] =
      1e3 * (Vec3(c.values[0], c.values[1], c.values[2]) - kCenter).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(c.values[3] - kRadius);
}

void BM_PclCircle(benchmark::State& state) {
  const auto cloud = ToPcl(Cached("circle", static_cast<int>(state.range(0))));
  pcl::SACSegmentation<pcl::PointNormal> seg;
  seg.setModelType(pcl::SACMODEL_CIRCLE3D);
  seg.setInputCloud(cloud);
  const auto c = RunPcl(state, seg);
  state.counters["pos_err_um"] =
      1e3 * (Vec3(c.values[0], c.values[1], c.values[2]) - kCenter).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(c.values[3] - kRadius);
  state.counters["dir_err_urad"] = AngleUrad(Vec3(c.values[4], c.values[5], c.values[6]), kAxis);
}

// PCL's cylinder model needs normals: it gets the exact ones, so its time excludes normal
// estimation (which would add a k-d tree search per point).
void BM_PclCylinder(benchmark::State& state) {
  const auto cloud = ToPcl(Cached("cylinder", static_cast<int>(state.range(0))));
  pcl::SACSegmentationFromNormals<pcl::PointNormal, pcl::PointNormal> seg;
  seg.setModelType(pcl::SACMODEL_CYLINDER);
  seg.setNormalDistanceWeight(0.1);
  seg.setRadiusLimits(0.0, 100.0);
  seg.setInputCloud(cloud);
  seg.setInputNormals(cloud);
  const auto c = RunPcl(state, seg);
  const Vec3 point(c.values[0], c.values[1], c.values[2]),
      axis(c.values[3], c.values[4], c.values[5]);
  state.counters["pos_err_um"] = 1e3 * (kCenter - point).cross(axis.normalized()).norm();
  state.counters["size_err_um"] = 1e3 * std::abs(c.values[6] - kRadius);
  state.counters["dir_err_urad"] = AngleUrad(axis, kAxis);
}

// ---- baseline: reading the points once (memory bandwidth bound) ----

void BM_MemoryReadBaseline(benchmark::State& state) {
  const auto& d = Cached("plane", static_cast<int>(state.range(0)));
  for (auto _ : state) {
    double sum = Eigen::Map<const Eigen::VectorXd>(d.points.data(), d.points.size()).sum();
    benchmark::DoNotOptimize(sum);
  }
  state.SetBytesProcessed(state.iterations() * d.points.size() * sizeof(double));
}

#define MLP_SIZES ->Arg(1000)->Arg(100000)->Arg(1000000)->Unit(benchmark::kMillisecond)
BENCHMARK(BM_MemoryReadBaseline) MLP_SIZES;
BENCHMARK(BM_MlpPlane) MLP_SIZES;
BENCHMARK(BM_PclPlane) MLP_SIZES;
BENCHMARK(BM_MlpSphere) MLP_SIZES;
BENCHMARK(BM_PclSphere) MLP_SIZES;
BENCHMARK(BM_MlpCircle) MLP_SIZES;
BENCHMARK(BM_MlpCirclePlaneFirst) MLP_SIZES;
BENCHMARK(BM_PclCircle) MLP_SIZES;
BENCHMARK(BM_MlpCylinder) MLP_SIZES;
BENCHMARK(BM_PclCylinder) MLP_SIZES;
BENCHMARK(BM_MlpLine) MLP_SIZES;
BENCHMARK(BM_MlpCone) MLP_SIZES;
BENCHMARK(BM_MlpEllipse) MLP_SIZES;
BENCHMARK(BM_MlpFlatnessMinZone) MLP_SIZES;
BENCHMARK(BM_MlpRoundnessMinZone) MLP_SIZES;
BENCHMARK(BM_MlpSphericityMinZone) MLP_SIZES;
BENCHMARK(BM_MlpCylindricityMinZone) MLP_SIZES;

}  // namespace

BENCHMARK_MAIN();
