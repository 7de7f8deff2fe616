#pragma once
// NIST's least-squares reference pairs (samples/data/nist, README there): a data set (.ds:
// count, then x y z per line) and its reference fit (.fit: numbers, layout per shape).

#include "mlp/geometry/types.h"

#include <filesystem>
#include <fstream>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::test {

inline geometry::Points3 ReadNistDs(const std::filesystem::path& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in.good()) << "cannot open " << path;
  int n = 0;
  in >> n;
  geometry::Points3 pts(3, n);
  for (int i = 0; i < n; ++i) in >> pts(0, i) >> pts(1, i) >> pts(2, i);
  EXPECT_FALSE(in.fail()) << "bad data set " << path;
  return pts;
}

inline std::vector<double> ReadNistFit(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::vector<double> v;
  for (double x; in >> x;) v.push_back(x);
  return v;
}

}  // namespace mlp::test
