#pragma once
/// @file Points gathered one by one (a std::vector of 2D or 3D vectors) as the column matrix
/// the fits take (Points2, Points3): the one copy every gatherer needs.

#include <vector>

#include <Eigen/Core>

namespace mlp::geometry {

template <int N>
Eigen::Matrix<double, N, Eigen::Dynamic> AsColumns(
    const std::vector<Eigen::Matrix<double, N, 1>>& points) {
  Eigen::Matrix<double, N, Eigen::Dynamic> m(N, static_cast<Eigen::Index>(points.size()));
  for (size_t i = 0; i < points.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = points[i];
  return m;
}

}  // namespace mlp::geometry
