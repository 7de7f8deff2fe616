#include "mlp/calib/robot_views.h"

#include "mlp/base/json_fields.h"
#include "mlp/calib/capture_io.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "board_json.h"
#include <Eigen/Geometry>

namespace mlp::calib {
namespace {

namespace jf = base::json_fields;
namespace fs = std::filesystem;
constexpr const char* kFormat = "mlprobe-robot-views/1";
constexpr int kMaxImages = 10000;

struct PoseConvention {
  double to_mm = 1000.0;
  bool xyzw = true;
  bool base_from_flange = true;
};

probe_fw::ChannelWeights Channels(const jf::json& c, const char* key, const std::string& where) {
  const jf::json& w = jf::Object<CaptureIoError>(c, key, where);
  const std::string at = where + "." + key;
  probe_fw::ChannelWeights out{true, jf::Number<CaptureIoError>(w, "r", at),
                               jf::Number<CaptureIoError>(w, "g", at),
                               jf::Number<CaptureIoError>(w, "b", at)};
  if (!(out.r > 0 || out.g > 0 || out.b > 0))
    throw CaptureIoError(at + ": no channel has a positive weight");
  return out;
}

PoseConvention Convention(const jf::json& p, const std::string& where) {
  PoseConvention c;
  const std::string layout = jf::Text<CaptureIoError>(p, "layout", where);
  if (layout != "position-quaternion-name")
    throw CaptureIoError(where + ".layout: \"" + layout +
                         "\" is not known; \"position-quaternion-name\" is");
  const std::string unit = jf::Text<CaptureIoError>(p, "position_unit", where);
  const std::string order = jf::Text<CaptureIoError>(p, "quaternion_order", where);
  const std::string pose = jf::Text<CaptureIoError>(p, "pose", where);
  if (unit != "m" && unit != "mm") throw CaptureIoError(where + ".position_unit: \"m\" or \"mm\"");
  if (order != "xyzw" && order != "wxyz")
    throw CaptureIoError(where + ".quaternion_order: \"xyzw\" or \"wxyz\"");
  if (pose != "base_from_flange" && pose != "flange_from_base")
    throw CaptureIoError(where + ".pose: \"base_from_flange\" or \"flange_from_base\"");
  c.to_mm = unit == "m" ? 1000.0 : 1.0;
  c.xyzw = order == "xyzw";
  c.base_from_flange = pose == "base_from_flange";
  return c;
}

// "[a, b, c]" with exactly n finite numbers.
std::vector<double> Bracketed(const std::string& line, size_t n, const std::string& where) {
  std::string s = line;
  const auto open = s.find('['), close = s.rfind(']');
  if (open == std::string::npos || close == std::string::npos || close < open)
    throw CaptureIoError(where + ": expected [" + std::to_string(n) + " numbers]");
  s = s.substr(open + 1, close - open - 1);
  for (char& ch : s) ch = ch == ',' ? ' ' : ch;
  std::istringstream in(s);
  std::vector<double> v;
  double x = 0;
  while (in >> x) v.push_back(x);
  in.clear();
  std::string rest;
  if ((in >> rest) || v.size() != n)
    throw CaptureIoError(where + ": expected [" + std::to_string(n) + " numbers]");
  for (double e : v)
    if (!std::isfinite(e)) throw CaptureIoError(where + ": a number is not finite");
  return v;
}

geometry::Pose3 ToPose(const std::vector<double>& xyz,
                       const std::vector<double>& q,
                       const PoseConvention& c,
                       const std::string& where) {
  const Eigen::Quaterniond quat = c.xyzw ? Eigen::Quaterniond(q[3], q[0], q[1], q[2])
                                         : Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  if (std::abs(quat.norm() - 1.0) > 1e-3)
    throw CaptureIoError(where + ": the quaternion's norm is " + std::to_string(quat.norm()) +
                         ", not 1 (wrong order or not a rotation?)");
  geometry::Pose3 pose = geometry::Pose3::Identity();
  pose.linear() = quat.normalized().toRotationMatrix();
  pose.translation() = geometry::Vec3(xyz[0], xyz[1], xyz[2]) * c.to_mm;
  return c.base_from_flange ? pose : pose.inverse();
}

std::vector<RobotImage> ReadPoses(const std::string& path,
                                  const PoseConvention& c,
                                  const fs::path& images,
                                  const std::string& default_extension) {
  std::istringstream in(ReadTextFile(path));
  std::vector<std::string> lines;
  std::vector<int> numbers;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    lines.push_back(line), numbers.push_back(n);
  }
  if (lines.size() % 3 != 0)
    throw CaptureIoError(path + ": " + std::to_string(lines.size()) +
                         " lines; three per image are expected (position, quaternion, name)");
  std::vector<RobotImage> out;
  for (size_t i = 0; i + 2 < lines.size(); i += 3) {
    const std::string at = path + ":" + std::to_string(numbers[i]);
    const auto xyz = Bracketed(lines[i], 3, at);
    const auto q = Bracketed(lines[i + 1], 4, path + ":" + std::to_string(numbers[i + 1]));
    std::string name = lines[i + 2];
    name.erase(name.find_last_not_of(" \t\r") + 1);
    name.erase(0, name.find_first_not_of(" \t"));
    if (name.find('/') != std::string::npos || name.find("..") != std::string::npos)
      throw CaptureIoError(path + ":" + std::to_string(numbers[i + 2]) +
                           ": an image name must be a plain file name");
    const std::string file = fs::path(name).has_extension() ? name : name + default_extension;
    out.push_back({name, (images / file).string(), ToPose(xyz, q, c, at)});
    if (out.size() > kMaxImages) throw CaptureIoError(path + ": more than 10000 images");
  }
  if (out.empty()) throw CaptureIoError(path + ": no poses");
  return out;
}

}  // namespace

RobotViews LoadRobotViews(const std::string& manifest_path) {
  const jf::json j =
      jf::ParseDocument<CaptureIoError>(ReadTextFile(manifest_path), kFormat, manifest_path);
  const std::string& where = manifest_path;
  const fs::path base = fs::path(manifest_path).parent_path();
  RobotViews v;
  v.board = ParseBoard(j, where);
  const jf::json& ch = jf::Object<CaptureIoError>(j, "channels", where);
  v.board_channels = Channels(ch, "board", where + ".channels");
  v.laser_channels = Channels(ch, "laser", where + ".channels");
  if (j.contains("stripe")) {
    const jf::json& s = jf::Object<CaptureIoError>(j, "stripe", where);
    const std::string at = where + ".stripe";
    v.stripe.max_width_px = jf::Integer<CaptureIoError>(s, "max_width_px", at);
    v.stripe.window_half_px = jf::Integer<CaptureIoError>(s, "window_half_px", at);
    v.stripe.min_amplitude_dn = jf::Number<CaptureIoError>(s, "min_amplitude_dn", at);
    v.stripe.speckle_sigma_px = jf::NumberOr<CaptureIoError>(s, "speckle_sigma_px", 0.0, at);
    if (v.stripe.max_width_px < 2 || v.stripe.max_width_px > 200 || v.stripe.window_half_px < 1 ||
        v.stripe.window_half_px > 100 || !(v.stripe.min_amplitude_dn > 0) ||
        !(v.stripe.speckle_sigma_px >= 0 && v.stripe.speckle_sigma_px <= 20))
      throw CaptureIoError(at +
                           ": max_width_px 2..200, window_half_px 1..100, min_amplitude_dn > 0, "
                           "speckle_sigma_px 0..20");
  }
  if (j.contains("raw")) v.raw = probe_fw::ParseRawBayer(j.at("raw"), where + ".raw");
  const fs::path images = base / jf::Text<CaptureIoError>(j, "images", where);
  const jf::json& p = jf::Object<CaptureIoError>(j, "poses", where);
  const PoseConvention c = Convention(p, where + ".poses");
  v.images = ReadPoses((base / jf::Text<CaptureIoError>(p, "file", where + ".poses")).string(), c,
                       images, v.raw.given ? ".raw" : ".png");
  return v;
}

}  // namespace mlp::calib
