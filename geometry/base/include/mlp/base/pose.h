#pragma once
/// @file The one pose type across the probe link, the cloud files and the host: a rigid
/// transform `Eigen::Isometry3d` (geometry::Pose3), and its one serial form, 16 numbers row by
/// row (the link's wire, the cloud file's `mcs_from_flange` comment). Converted here only.

#include <array>
#include <cmath>
#include <string>

#include <Eigen/Geometry>

namespace mlp::base {

/// A pose's 4 x 4 matrix row by row, the last row 0 0 0 1.
inline std::array<double, 16> RowMajor(const Eigen::Isometry3d& pose) {
  std::array<double, 16> m{};
  for (std::size_t r = 0; r < 4; ++r)
    for (std::size_t c = 0; c < 4; ++c)
      m[4 * r + c] = pose.matrix()(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c));
  return m;
}

/// 16 numbers row by row as a rigid transform; the reason in `why` and false when they are not
/// one: a number not finite, a last row other than 0 0 0 1, a rotation part whose columns are not
/// orthonormal within 1e-6 (poses come from a controller as doubles; anything further off is
/// not a pose), or a reflection.
inline bool PoseFromRowMajor(const std::array<double, 16>& m,
                             Eigen::Isometry3d* pose,
                             std::string* why) {
  for (double v : m) {
    if (!std::isfinite(v)) return *why = "the pose holds a non-finite number", false;
  }
  if (m[12] != 0.0 || m[13] != 0.0 || m[14] != 0.0 || m[15] != 1.0)
    return *why = "the pose's last row is not 0 0 0 1", false;
  Eigen::Matrix4d h;
  for (std::size_t r = 0; r < 4; ++r)
    for (std::size_t c = 0; c < 4; ++c)
      h(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = m[4 * r + c];
  constexpr double kOrthonormalTol = 1e-6;
  const Eigen::Matrix3d r = h.topLeftCorner<3, 3>();
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= kOrthonormalTol))
    return *why = "the pose's rotation is not orthonormal", false;
  if (r.determinant() < 0.0) return *why = "the pose's rotation is a reflection", false;
  pose->matrix() = h;
  return true;
}

}  // namespace mlp::base
