#pragma once
// Words for directions of the calibration's parameter space, shared by the hand-eye and the
// quick re-calibration (internal to calib).

#include <cmath>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace mlp::calib::detail {

using Vec9 = Eigen::Matrix<double, 9, 1>;

inline const char* const kAxis[3] = {"X", "Y", "Z"};

// Words for a direction of the scaled parameter space (rotation x lever | t | c), and in the
// hand-eye with a sensor model (scale x lever along probe X, Y, Z | depth bias with incidence).
inline std::string Describe(const Eigen::VectorXd& v) {
  std::vector<std::string> parts;
  constexpr double kShown = 0.25;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v(k)) > kShown)
      parts.push_back(std::string("M's rotation about flange ") + kAxis[k]);
  }
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v(3 + k)) > kShown)
      parts.push_back(std::string("M's offset along flange ") + kAxis[k]);
  }
  for (int k = 0; k < 3; ++k) {
    if (std::abs(v(6 + k)) > kShown)
      parts.push_back(std::string("the sphere centre's ") + kAxis[k]);
  }
  for (int k = 0; k < 3 && 9 + k < v.size(); ++k) {
    if (std::abs(v(9 + k)) > kShown)
      parts.push_back(std::string("the sensor's scale along probe ") + kAxis[k]);
  }
  if (v.size() > 12 && std::abs(v(12)) > kShown)
    parts.push_back("the sensor's depth bias with the angle of incidence");
  std::string s;
  for (size_t i = 0; i < parts.size(); ++i) {
    if (i > 0) s.append(i + 1 == parts.size() ? " and " : ", ");
    s.append(parts[i]);
  }
  return s;
}

}  // namespace mlp::calib::detail
