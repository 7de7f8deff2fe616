#include "mlp/calib/capture_io.h"

#include "mlp/calib/hand_eye.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include <opencv2/core.hpp>

namespace mlp::calib {

geometry::Points3 LoadFileStorageProfile(const std::string& path, const std::string& key) {
  std::vector<double> values;
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) throw CaptureIoError("cannot open " + path);
    const cv::FileNode node = fs[key];
    if (node.empty() || !node.isSeq()) throw CaptureIoError(path + ": no list '" + key + "'");
    node >> values;
  } catch (const cv::Exception& e) {
    throw CaptureIoError(path + ": " + e.what());
  }
  if (values.size() % 3 != 0)
    throw CaptureIoError(path + ": '" + key + "' holds " + std::to_string(values.size()) +
                         " numbers, not x y z triplets");
  geometry::Points3 points(3, static_cast<Eigen::Index>(values.size() / 3));
  for (size_t i = 0; i < values.size(); ++i)
    points(static_cast<Eigen::Index>(i % 3), static_cast<Eigen::Index>(i / 3)) = values[i];
  return points;
}

std::vector<geometry::Pose3> LoadXyzWprPoses(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw CaptureIoError("cannot open " + path);
  std::vector<geometry::Pose3> poses;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream s(line);
    double v[6];
    std::string rest;
    if (!(s >> v[0] >> v[1] >> v[2] >> v[3] >> v[4] >> v[5]) || (s >> rest))
      throw CaptureIoError(path + ":" + std::to_string(number) + ": expected x y z w p r");
    for (double x : v) {
      if (!std::isfinite(x))
        throw CaptureIoError(path + ":" + std::to_string(number) + ": not finite");
    }
    poses.push_back(PoseFromXyzWpr(v[0], v[1], v[2], v[3], v[4], v[5]));
  }
  return poses;
}

}  // namespace mlp::calib
