#include "mlp/host/cloud_io.h"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <vector>

#include "../plugins/pcl_reader.h"
#include <dlfcn.h>
#include <unistd.h>

namespace mlp::host {
namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Cloud FromFlat(const std::vector<double>& xyz) {
  Cloud cloud;
  const size_t n = xyz.size() / 3;
  cloud.points.resize(3, static_cast<Eigen::Index>(n));
  Eigen::Index kept = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
    if (p.allFinite()) {
      cloud.points.col(kept++) = p;
    } else {
      ++cloud.dropped_non_finite;
    }
  }
  cloud.points.conservativeResize(3, kept);
  return cloud;
}

// The plug-in sits in ../lib relative to the program (build/bin -> build/lib), or is found by
// the dynamic loader's usual search.
MlpReadPclCloudFn LoadPclReader() {
  static MlpReadPclCloudFn fn = []() -> MlpReadPclCloudFn {
    std::vector<std::string> candidates;
    std::error_code ec;
    const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (!ec) {
      candidates.push_back((exe.parent_path() / "../lib/libmlp_pcl_reader.so").string());
      candidates.push_back((exe.parent_path() / "../../lib/libmlp_pcl_reader.so").string());
    }
    candidates.push_back("libmlp_pcl_reader.so");
    for (const auto& c : candidates) {
      if (void* h = dlopen(c.c_str(), RTLD_NOW | RTLD_LOCAL)) {
        return reinterpret_cast<MlpReadPclCloudFn>(dlsym(h, "mlp_read_pcl_cloud"));
      }
    }
    return nullptr;
  }();
  return fn;
}

Cloud ReadWithPcl(const std::string& path) {
  const MlpReadPclCloudFn read = LoadPclReader();
  if (read == nullptr) {
    throw CloudIoError("the PCL reader plug-in libmlp_pcl_reader.so was not found (needed for " +
                       path + ")");
  }
  double* xyz = nullptr;
  size_t n = 0;
  char err[512] = {0};
  if (read(path.c_str(), &xyz, &n, err, sizeof(err)) != 0) throw CloudIoError(err);
  std::vector<double> flat(xyz, xyz + 3 * n);
  std::free(xyz);
  return FromFlat(flat);
}

}  // namespace

Cloud ParseXyzText(std::istream& in, const std::string& name) {
  std::vector<double> flat;
  std::string line;
  size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    std::istringstream ls(line);
    double v[3];
    int count = 0;
    std::string token;
    while (ls >> token) {
      char* end = nullptr;
      const double x = std::strtod(token.c_str(), &end);
      if (end == token.c_str() || *end != '\0') {
        // NOLINTNEXTLINE(performance-inefficient-string-concatenation): an error, built once
        throw CloudIoError(name + ":" + std::to_string(line_no) + ": '" + token +
                           "' is not a number");
      }
      if (count < 3) v[count] = x;
      ++count;
    }
    if (count == 0) continue;
    if (count != 3) {
      throw CloudIoError(name + ":" + std::to_string(line_no) +
                         ": expected 3 numbers (x y z), got " + std::to_string(count));
    }
    flat.insert(flat.end(), v, v + 3);
  }
  if (in.bad()) throw CloudIoError(name + ": read error");
  return FromFlat(flat);
}

Cloud ReadCloud(const std::string& path) {
  if (path == "-") return ParseXyzText(std::cin, "stdin");
  if (!std::filesystem::is_regular_file(path)) throw CloudIoError(path + ": no such file");
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  if (ext == ".pcd" || ext == ".ply") return ReadWithPcl(path);
  if (ext == ".xyz" || ext == ".txt" || ext == ".asc" || ext.empty()) {
    std::ifstream in(path);
    if (!in) throw CloudIoError(path + ": cannot open");
    return ParseXyzText(in, path);
  }
  throw CloudIoError(path + ": unknown cloud format '" + ext + "' (use .xyz, .pcd or .ply)");
}

}  // namespace mlp::host
