#include "mlp/calib/capture_io.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/calib/hand_eye.h"

#include <cmath>
#include <filesystem>
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

namespace mlp::calib {
namespace {

namespace jf = base::json_fields;
constexpr const char* kManifestFormat = "mlprobe-sphere-captures/1";

geometry::Pose3 CapturePose(const jf::json& c, const std::string& where) {
  if (c.contains("mcs_from_flange"))
    return jf::Pose<CaptureIoError>(jf::Object<CaptureIoError>(c, "mcs_from_flange", where),
                                    where + ".mcs_from_flange");
  const char* kXyzWpr = "mcs_from_flange_xyzwpr";
  if (c.contains(kXyzWpr) && c.at(kXyzWpr).is_array() && c.at(kXyzWpr).size() == 6) {
    double v[6];
    for (size_t k = 0; k < 6; ++k) {
      if (!c.at(kXyzWpr)[k].is_number())
        throw CaptureIoError(where + ".mcs_from_flange_xyzwpr must hold 6 numbers");
      v[k] = c.at(kXyzWpr)[k].get<double>();
    }
    return PoseFromXyzWpr(v[0], v[1], v[2], v[3], v[4], v[5]);
  }
  throw CaptureIoError(where +
                       " needs mcs_from_flange {translation_mm, rotation_vector_rad} or "
                       "mcs_from_flange_xyzwpr [x, y, z, w, p, r]");
}

geometry::Points3 ReadPoints(const std::filesystem::path& path,
                             const jf::json& c,
                             const std::string& where,
                             const CloudReader& read_cloud) {
  const std::string ext = path.extension().string();
  if (ext == ".yml" || ext == ".yaml") {
    const std::string key = c.contains("cloud_key")
                                ? jf::Text<CaptureIoError>(c, "cloud_key", where)
                                : std::string("scan_line");
    return LoadFileStorageProfile(path.string(), key);
  }
  return read_cloud(path.string());
}

}  // namespace

SphereCaptureManifest LoadSphereCaptureManifest(const std::string& path,
                                                const CloudReader& read_cloud) {
  const jf::json j = jf::ParseDocument<CaptureIoError>(base::ReadFileAs<CaptureIoError>(path),
                                                       kManifestFormat, path);
  SphereCaptureManifest m;
  m.probe_serial = jf::Text<CaptureIoError>(j, "probe_serial", "manifest");
  m.sphere_radius_mm = jf::Number<CaptureIoError>(j, "sphere_radius_mm", "manifest");
  if (j.contains("known_centre_mcs_mm")) {
    const auto& k = jf::Object<CaptureIoError>(j, "known_centre_mcs_mm", "manifest");
    const char* axes[3] = {"x", "y", "z"};
    for (size_t a = 0; a < 3; ++a) {
      if (k.contains(axes[a]))
        m.known_centre_mcs[a] =
            jf::Number<CaptureIoError>(k, axes[a], "manifest.known_centre_mcs_mm");
    }
  }
  // What counts as determined: a machine tool wants 0.05 mm (the default), a robot cell accepts
  // more; the lever is about the probe's stand-off.
  if (j.contains("max_std_mm"))
    m.max_std_mm = jf::Number<CaptureIoError>(j, "max_std_mm", "manifest");
  if (j.contains("lever_mm")) m.lever_mm = jf::Number<CaptureIoError>(j, "lever_mm", "manifest");
  if (!j.contains("captures") || !j.at("captures").is_array())
    throw CaptureIoError("manifest.captures must be an array");
  const std::filesystem::path base = std::filesystem::path(path).parent_path();
  for (size_t i = 0; i < j.at("captures").size(); ++i) {
    const auto& c = j.at("captures")[i];
    const std::string where = "manifest.captures[" + std::to_string(i) + "]";
    SphereCapture cap;
    cap.id = jf::Text<CaptureIoError>(c, "id", where);
    cap.mcs_from_flange = CapturePose(c, where);
    cap.single_profile = jf::FlagOr<CaptureIoError>(c, "single_profile", false, where);
    cap.points_in_probe =
        ReadPoints(base / jf::Text<CaptureIoError>(c, "cloud", where), c, where, read_cloud);
    m.captures.push_back(std::move(cap));
  }
  return m;
}

}  // namespace mlp::calib
