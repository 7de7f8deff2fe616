// Robust fits on real sensor clouds from PCL's test data (../shared/data/pcl).

#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"
#include "mlp/host/cloud_io.h"

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kMetresToMm = 1000.0;
constexpr double kDeg = M_PI / 180.0;

Points3 Select(const Points3& p, const std::vector<int>& idx) {
  Points3 out(3, idx.size());
  for (size_t k = 0; k < idx.size(); ++k) out.col(k) = p.col(idx[k]);
  return out;
}

double AngleUpToSign(const Vec3& a, const Vec3& b) {
  return std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

// A noisy wall scan with a quarter of its points off the plane: least squares is ruined, the
// robust fit keeps the plane and says which points it used.
TEST(RealClouds, RobustPlaneOnPclWallScan) {
  const auto cloud = host::ReadCloud(test::RepoDataDir() / "pcl" / "sac_plane_test.pcd");
  ASSERT_EQ(cloud.points.cols(), 3283);
  const Points3 p = cloud.points * kMetresToMm;
  const auto ls = FitPlane(p);
  RobustOptions automatic;
  const auto robust = FitPlaneRobust(p, automatic);
  RobustOptions fixed;
  fixed.inlier_threshold_mm = 10.0;
  const auto robust10 = FitPlaneRobust(p, fixed);
  EXPECT_GT(static_cast<double>(robust.inliers.size()), 0.6 * static_cast<double>(p.cols()));
  EXPECT_LT(robust.fit.stats.rms, 5.0);                  // mm: the wall's own noise
  EXPECT_GT(ls.stats.rms, 10.0 * robust.fit.stats.rms);  // outliers dominate plain LS
  EXPECT_LT(AngleUpToSign(robust.fit.shape.normal, robust10.fit.shape.normal), 0.5 * kDeg);
  // Same seed, same answer.
  const auto again = FitPlaneRobust(p, automatic);
  EXPECT_EQ(again.inliers, robust.inliers);
}

// PCL's cylinder segmentation tutorial scene: crop to the table top, remove the table plane,
// then the mug is a cylinder of radius about 39.6 mm (PCL's own estimate) standing on the table.
TEST(RealClouds, RobustCylinderFindsTheMug) {
  const auto cloud =
      host::ReadCloud(test::RepoDataDir() / "pcl" / "table_scene_mug_stereo_textured.pcd");
  EXPECT_EQ(cloud.points.cols() + static_cast<Eigen::Index>(cloud.dropped_non_finite), 640 * 480);
  std::vector<int> near;
  for (Eigen::Index i = 0; i < cloud.points.cols(); ++i) {
    if (cloud.points(2, i) < 1.5) near.push_back(static_cast<int>(i));  // PCL's pass-through
  }
  const Points3 scene = Select(cloud.points, near) * kMetresToMm;
  RobustOptions plane_opts;
  plane_opts.inlier_threshold_mm = 20.0;
  const auto table = FitPlaneRobust(scene, plane_opts);
  std::vector<bool> on_table(scene.cols(), false);
  for (int i : table.inliers) on_table[i] = true;
  std::vector<int> rest;
  for (Eigen::Index i = 0; i < scene.cols(); ++i) {
    if (!on_table[i]) rest.push_back(static_cast<int>(i));
  }
  const Points3 objects = Select(scene, rest);
  for (double threshold_mm : {5.0, 0.0}) {
    RobustOptions opts;
    opts.inlier_threshold_mm = threshold_mm;
    const auto mug = FitCylinderRobust(objects, opts);
    SCOPED_TRACE(threshold_mm);
    constexpr double kMugRadiusTolMm = 1.0;  // stereo noise ~1.5 mm RMS
    EXPECT_NEAR(mug.fit.shape.radius, 39.6, kMugRadiusTolMm);
    EXPECT_LT(AngleUpToSign(mug.fit.shape.axis, table.fit.shape.normal), 2.0 * kDeg);
    EXPECT_GT(static_cast<double>(mug.inliers.size()), 0.7 * static_cast<double>(objects.cols()));
  }
}

}  // namespace
}  // namespace mlp::geometry
