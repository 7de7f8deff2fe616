#pragma once
// Ground truth for camera/projector calibration tests: the probe as built and how a model's
// triangulation is judged against it.

#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/triangulate.h"

#include <cmath>
#include <vector>

#include <Eigen/Geometry>

namespace mlp::test {

/// The reference design with the tolerances of assembly (0.4-0.8 % in the focal lengths, 2-3 px
/// in the centres, 0.7 mm and 0.3 degrees in the projector's pose): what calibration recovers.
inline probe_fw::ProbeModel AsBuilt(probe_fw::ProbeModel m) {
  using geometry::Vec3;
  m.camera.fx_px *= 1.004, m.camera.fy_px *= 1.0042;
  m.camera.cx_px += 3.1, m.camera.cy_px -= 2.2;
  m.camera.k1 -= 0.006, m.camera.k2 += 0.01;
  m.projector.f_px *= 1.008, m.projector.c_px += 2.5;
  auto& p = m.projector.camera_from_projector;
  p.translation() += Vec3(0.7, -0.4, 0.5);
  p.linear() =
      Eigen::AngleAxisd(0.005, Vec3(0.3, 1.0, -0.2).normalized()).toRotationMatrix() * p.linear();
  return m;
}

struct TriangulationError {
  double rms_mm = 0, max_mm = 0;  ///< after the best rigid alignment
  double unaligned_rms_mm = 0;
  std::size_t points = 0;
};

/// Triangulated points against true ones, before and after the best rigid alignment.
inline TriangulationError RigidlyAligned(const std::vector<geometry::Vec3>& got,
                                         const std::vector<geometry::Vec3>& want) {
  Eigen::Matrix3Xd a(3, got.size()), b(3, want.size());
  for (std::size_t i = 0; i < got.size(); ++i)
    a.col(static_cast<long>(i)) = got[i], b.col(static_cast<long>(i)) = want[i];
  TriangulationError e;
  e.points = got.size();
  e.unaligned_rms_mm = std::sqrt((a - b).colwise().squaredNorm().mean());
  const Eigen::Matrix4d t = Eigen::umeyama(a, b, false);
  const Eigen::Matrix3Xd aligned =
      (t.topLeftCorner<3, 3>() * a).colwise() + t.topRightCorner<3, 1>();
  e.rms_mm = std::sqrt((aligned - b).colwise().squaredNorm().mean());
  e.max_mm = std::sqrt((aligned - b).colwise().squaredNorm().maxCoeff());
  return e;
}

/// Calls f(u, w, xy, z) over the working volume: planes z = 105, 120, 135 mm, the whole image
/// but 100 px every 150 px, xy the pixel's undistorted normalised coordinates.
template <class F>
void OverTheWorkingVolume(const probe_fw::CameraModel& camera, F f) {
  for (double z : {105.0, 120.0, 135.0}) {
    for (double u = 100; u < camera.width_px - 100; u += 150) {
      for (double w = 100; w < camera.height_px - 100; w += 150)
        f(u, w, camera.Undistort(geometry::Vec2(u, w)), z);
    }
  }
}

/// True surface points over the working volume seen by the true probe, triangulated with
/// `model`. The probe frame is what calibration defines (a principal point 0.5 px off turns it
/// by 1e-4 rad) and the hand-eye measures M in that frame, so the error that matters is after
/// the best rigid alignment (Umeyama, no scale).
inline TriangulationError TriangulationVsTruth(const probe_fw::ProbeModel& truth,
                                               const probe_fw::ProbeModel& model) {
  using geometry::Vec3;
  std::vector<Vec3> got, want;
  OverTheWorkingVolume(truth.camera, [&](double u, double w, const geometry::Vec2& xy, double z) {
    const Vec3 p(xy.x() * z, xy.y() * z, z);
    const double column = truth.projector.ColumnOf(p);
    if (column < 0 || column > truth.projector.columns - 1) return;
    got.push_back(probe_fw::Triangulate(model, u, w, column).value()), want.push_back(p);
  });
  return RigidlyAligned(got, want);
}

}  // namespace mlp::test
