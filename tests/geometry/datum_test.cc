// Datum frames from fitted elements: a part placed at a known pose in the machine is measured
// (noisy points, fits), and the alignment must return that pose.

#include "mlp/geometry/datum.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"

#include <random>

#include "seeded_draw.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

constexpr double kOriginTolMm = 0.002;  // 2 um from 1 um point noise
constexpr double kAngleTolDeg = 0.002;  // 35 urad

// The part's true pose in the machine: rotated 12.5 deg about Z, tilted slightly, offset.
Pose3 TruePose() {
  Pose3 p = Pose3::Identity();
  p.linear() = (Eigen::AngleAxisd(12.5 * M_PI / 180, Vec3::UnitZ()) *
                Eigen::AngleAxisd(0.3 * M_PI / 180, Vec3::UnitX()))
                   .toRotationMatrix();
  p.translation() = Vec3(-412.5, 118.25, -305.0);
  return p;
}

Points3 Noisy(const Pose3& mcs_from_work, std::vector<Vec3> pts_in_work, std::mt19937_64& rng) {
  std::normal_distribution<double> noise(0.0, 0.001);
  Points3 out(3, pts_in_work.size());
  for (size_t i = 0; i < pts_in_work.size(); ++i) {
    out.col(i) = mcs_from_work * pts_in_work[i] + test::DrawVec3(noise, rng);
  }
  return out;
}

// Seed 004 worked example: plane A (top face), holes B at the origin and C on +Y.
TEST(Datum, PlaneCircleCircleRecoversThePartPose) {
  std::mt19937_64 rng(4);
  const Pose3 truth = TruePose();
  std::uniform_real_distribution<double> uni(-40.0, 40.0);
  std::vector<Vec3> face, hole_b, hole_c;
  for (int i = 0; i < 400; ++i) {
    const Vec2 xy = test::DrawVec2(uni, rng);
    face.push_back(Vec3(xy.x(), xy.y() + 30, 0));
  }
  for (int i = 0; i < 90; ++i) {
    const double t = 2 * M_PI * i / 90;
    hole_b.push_back(Vec3(6 * std::cos(t), 6 * std::sin(t), -2.0));
    hole_c.push_back(Vec3(4 * std::cos(t), 60 + 4 * std::sin(t), -2.0));
  }
  const auto a = FitPlane(Noisy(truth, face, rng));
  const auto b = FitCircle3(Noisy(truth, hole_b, rng));
  const auto c = FitCircle3(Noisy(truth, hole_c, rng));
  Plane plane_a = a.shape;
  if (plane_a.normal.dot(truth.linear().col(2)) < 0) plane_a.normal = -plane_a.normal;
  const Pose3 mcs_from_work = DatumPlaneCircleCircle(plane_a, b.shape.center, c.shape.center);
  EXPECT_LT((mcs_from_work.translation() - truth.translation()).norm(), kOriginTolMm);
  const double angle =
      Eigen::AngleAxisd(mcs_from_work.linear().transpose() * truth.linear()).angle();
  EXPECT_LT(angle * 180 / M_PI, kAngleTolDeg);
  const auto reading = ReadWorkOffset(mcs_from_work);
  EXPECT_NEAR(reading.rotation_z_deg, 12.5, kAngleTolDeg);
  EXPECT_NEAR(reading.tilt_deg, 0.3, kAngleTolDeg);
  EXPECT_NEAR(reading.origin_mm.x(), -412.5, kOriginTolMm);
}

TEST(Datum, PlaneLinePointRecoversThePartPose) {
  std::mt19937_64 rng(5);
  const Pose3 truth = TruePose();
  std::uniform_real_distribution<double> uni(0.0, 80.0);
  std::vector<Vec3> face, edge;
  for (int i = 0; i < 300; ++i) {
    const Vec2 xy = test::DrawVec2(uni, rng);
    face.push_back(Vec3(xy.x() + 5, xy.y() + 5, 0));
  }
  for (int i = 0; i < 100; ++i) edge.push_back(Vec3(uni(rng), 0, -1.5));  // side face at y = 0
  const auto plane = FitPlane(Noisy(truth, face, rng));
  const auto line = FitLine3(Noisy(truth, edge, rng));
  const Vec3 stop = truth * Vec3(0, 12, -3);  // end-face contact at x = 0
  Plane p = plane.shape;
  if (p.normal.dot(truth.linear().col(2)) < 0) p.normal = -p.normal;
  Line3 l = line.shape;
  if (l.direction.dot(truth.linear().col(0)) < 0) l.direction = -l.direction;
  const Pose3 mcs_from_work = DatumPlaneLinePoint(p, l, stop);
  // Origin: on the top face above the edge line, at the stop's X.
  EXPECT_LT((mcs_from_work.translation() - truth.translation()).norm(), kOriginTolMm);
  const double angle =
      Eigen::AngleAxisd(mcs_from_work.linear().transpose() * truth.linear()).angle();
  EXPECT_LT(angle * 180 / M_PI, kAngleTolDeg);
  // Round trip: machine points mapped to work and back.
  const Points3 pts = Noisy(truth, face, rng);
  const Points3 back =
      TransformPoints(mcs_from_work, TransformPoints(mcs_from_work.inverse(), pts));
  EXPECT_LT((back - pts).cwiseAbs().maxCoeff(), 1e-9);
}

TEST(Datum, LinePerpendicularToThePlaneIsRejected) {
  const Plane plane{Vec3::Zero(), Vec3::UnitZ()};
  try {
    DatumPlaneLinePoint(plane, Line3{Vec3::Zero(), Vec3::UnitZ()}, Vec3::Zero());
    FAIL() << "expected kDegenerate";
  } catch (const GeometryError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kDegenerate);
  }
}

}  // namespace
}  // namespace mlp::geometry
