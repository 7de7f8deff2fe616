#include "mlp/probe_fw/cloud_file.h"

#include "mlp/base/files.h"
#include "mlp/base/pose.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string_view>

namespace mlp::probe_fw {
namespace {

void PutFloat(std::ostream& out, double v) {
  const float f = static_cast<float>(v);
  char bytes[4];
  std::memcpy(bytes, &f, 4);  // x86-64 and ARMv8 Linux are little-endian, as the header says
  out.write(bytes, 4);
}

// Comments are one line each: strip line breaks a caller might pass in an id.
std::string OneLine(std::string s) {
  for (char& c : s) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return s;
}

// " %.17g" per number: exact in a comment.
void PutExact(std::ostream& out, double v) {
  char number[32];
  std::snprintf(number, sizeof number, " %.17g", v);
  out << number;
}

}  // namespace

void WriteCloudPly(const std::string& path,
                   const std::vector<double>& xyz,
                   const std::vector<float>& quality,
                   const CloudFileMeta& meta) {
  if (xyz.size() != 3 * quality.size())
    throw CloudFileError("cloud: " + std::to_string(xyz.size()) + " coordinates for " +
                         std::to_string(quality.size()) + " points");
  const auto write = [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\n"
        << "comment mlprobe cloud, " << OneLine(meta.frame) << " frame, millimetres\n"
        << "comment probe_serial " << OneLine(meta.probe_serial) << "\n"
        << "comment calibration_id " << OneLine(meta.calibration_id) << "\n"
        << "comment capture_id " << OneLine(meta.capture_id) << "\n";
    if (meta.mcs_from_flange) {
      out << "comment mcs_from_flange";  // row-major, exact (17 significant digits)
      for (double v : base::RowMajor(*meta.mcs_from_flange)) PutExact(out, v);
      out << "\n";
    }
    if (meta.edge) {
      out << "comment edge";  // normal, first ray, last ray, rms px, points (base/edge_sight.h)
      for (double v : base::EdgeSightNumbers(*meta.edge)) PutExact(out, v);
      out << " " << meta.edge->points << "\n";
    }
    out << "element vertex " << quality.size() << "\n"
        << "property float x\nproperty float y\nproperty float z\nproperty float quality\n"
        << "end_header\n";
    for (size_t i = 0; i < quality.size(); ++i) {
      PutFloat(out, xyz[3 * i]);
      PutFloat(out, xyz[3 * i + 1]);
      PutFloat(out, xyz[3 * i + 2]);
      PutFloat(out, quality[i]);
    }
  };
  try {
    base::WriteFileAtomically(path, write);
  } catch (const base::FileError& e) {
    throw CloudFileError(std::string("cloud: ") + e.what());
  }
}

namespace {

CloudFileError Bad(const std::string& path, const std::string& what) {
  return CloudFileError("cloud " + path + ": " + what);
}

// A "comment <name> <rest>" line of the header: the frame, the probe, the calibration, the
// capture and the flange pose the cloud was taken at (WriteCloudPly writes them).
void ReadMetaComment(const std::string& path,
                     const std::string& name,
                     const std::string& rest,
                     CloudFileMeta* meta) {
  constexpr std::string_view kCloud = "cloud, ", kFrame = " frame, millimetres";
  if (name == "mlprobe" && rest.size() > kCloud.size() + kFrame.size() &&
      rest.compare(0, kCloud.size(), kCloud) == 0 &&
      rest.compare(rest.size() - kFrame.size(), kFrame.size(), kFrame) == 0)
    meta->frame = rest.substr(kCloud.size(), rest.size() - kCloud.size() - kFrame.size());
  if (name == "probe_serial") meta->probe_serial = rest;
  if (name == "calibration_id") meta->calibration_id = rest;
  if (name == "capture_id") meta->capture_id = rest;
  if (name == "mcs_from_flange") {
    std::array<double, 16> h{};
    std::istringstream numbers(rest);
    for (double& v : h)
      if (!(numbers >> v)) throw Bad(path, "mcs_from_flange must hold 16 numbers");
    Eigen::Isometry3d pose;
    std::string why;
    if (!base::PoseFromRowMajor(h, &pose, &why)) throw Bad(path, "mcs_from_flange: " + why);
    meta->mcs_from_flange = pose;
  }
  if (name == "edge") {
    std::array<double, 10> v{};
    long long points = -1;
    std::istringstream numbers(rest);
    for (double& x : v)
      if (!(numbers >> x)) throw Bad(path, "edge must hold 10 numbers and a point count");
    if (!(numbers >> points) || points < 0 || points > (1ll << 31))
      throw Bad(path, "edge must hold 10 numbers and a point count");
    base::EdgeSight edge;
    std::string why;
    if (!base::EdgeSightFromNumbers(v, static_cast<std::uint32_t>(points), &edge, &why))
      throw Bad(path, "edge: " + why);
    meta->edge = edge;
  }
}

// The header after its format line, up to end_header: the comments into `f`, the vertex count
// returned (-1 without an element line). Only x y z quality as floats is accepted.
long long ReadHeader(std::istream& in, const std::string& path, CloudFile* f) {
  long long vertices = -1;
  std::vector<std::string> properties;
  std::string line;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "comment") {
      std::string name, rest;
      words >> name;
      std::getline(words, rest);
      if (!rest.empty() && rest[0] == ' ') rest.erase(0, 1);
      ReadMetaComment(path, name, rest, &f->meta);
    } else if (key == "element") {
      std::string name;
      words >> name >> vertices;
      if (name != "vertex" || vertices < 0) throw Bad(path, "unexpected element " + line);
    } else if (key == "property") {
      std::string type, name;
      words >> type >> name;
      if (type != "float") throw Bad(path, "property " + name + " is not float");
      properties.push_back(name);
    }
  }
  if (line != "end_header") throw Bad(path, "the header does not end");
  if (properties != std::vector<std::string>{"x", "y", "z", "quality"})
    throw Bad(path, "properties must be x y z quality");
  return vertices;
}

// The points, bounded before allocating: the file must hold what the header says.
void ReadBody(std::istream& in, const std::string& path, long long vertices, CloudFile* f) {
  const auto body_start = in.tellg();
  in.seekg(0, std::ios::end);
  const auto body = static_cast<long long>(in.tellg() - body_start);
  in.seekg(body_start);
  if (vertices < 0 || body != vertices * 16)
    throw Bad(path, "holds " + std::to_string(body) + " bytes for " + std::to_string(vertices) +
                        " points");
  f->xyz.resize(static_cast<size_t>(3 * vertices));
  f->quality.resize(static_cast<size_t>(vertices));
  float v[4];
  for (long long i = 0; i < vertices; ++i) {
    in.read(reinterpret_cast<char*>(v), sizeof v);
    for (int k = 0; k < 3; ++k) f->xyz[static_cast<size_t>(3 * i + k)] = v[k];
    f->quality[static_cast<size_t>(i)] = v[3];
  }
  if (!in) throw Bad(path, "cannot read the points");
}

}  // namespace

CloudFile ReadCloudPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CloudFileError("cloud: cannot read " + path);
  std::string line;
  if (!std::getline(in, line) || line != "ply") throw Bad(path, "not a PLY file");
  if (!std::getline(in, line) || line != "format binary_little_endian 1.0")
    throw Bad(path, "not binary little-endian");
  CloudFile f;
  const long long vertices = ReadHeader(in, path, &f);
  ReadBody(in, path, vertices, &f);
  return f;
}

}  // namespace mlp::probe_fw
