#pragma once
// Seeded test data drawn in one order on every compiler. C++ leaves the order in which a call's
// arguments (and an overloaded operator's operands) are evaluated to the compiler: GCC 12 takes
// them last first, clang 14 first first, so Vec3(n(g), n(g), n(g)) gave the two compilers
// different data from the same seed. These draw one number per statement, the last coordinate
// first: the order GCC gave the one-expression forms the tests were written with, so the data
// and every figure measured on it stay what they were (docs/DEVELOPING.md, seeded draws).

#include <Eigen/Core>

namespace mlp::test {

/// (x, y, z) from three draws of `dist`, z drawn first.
template <class Dist, class Gen>
Eigen::Vector3d DrawVec3(Dist& dist, Gen& gen) {
  const double z = dist(gen);
  const double y = dist(gen);
  const double x = dist(gen);
  return {x, y, z};
}

/// (x, y) from two draws of `dist`, y drawn first.
template <class Dist, class Gen>
Eigen::Vector2d DrawVec2(Dist& dist, Gen& gen) {
  const double y = dist(gen);
  const double x = dist(gen);
  return {x, y};
}

}  // namespace mlp::test
