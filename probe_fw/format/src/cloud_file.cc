#include "mlp/probe_fw/cloud_file.h"

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace mlp::probe_fw {
namespace {

void PutFloat(std::ofstream& out, double v) {
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

}  // namespace

void WriteCloudPly(const std::string& path,
                   const std::vector<double>& xyz,
                   const std::vector<float>& quality,
                   const CloudFileMeta& meta) {
  if (xyz.size() != 3 * quality.size())
    throw CloudFileError("cloud: " + std::to_string(xyz.size()) + " coordinates for " +
                         std::to_string(quality.size()) + " points");
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << "ply\nformat binary_little_endian 1.0\n"
        << "comment mlprobe cloud, probe frame, millimetres\n"
        << "comment probe_serial " << OneLine(meta.probe_serial) << "\n"
        << "comment calibration_id " << OneLine(meta.calibration_id) << "\n"
        << "comment capture_id " << OneLine(meta.capture_id) << "\n";
    if (meta.mcs_from_flange) {
      out << "comment mcs_from_flange";  // row-major, exact (17 significant digits)
      char number[32];
      for (double v : *meta.mcs_from_flange) {
        std::snprintf(number, sizeof number, " %.17g", v);
        out << number;
      }
      out << "\n";
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
    if (!out) throw CloudFileError("cloud: cannot write " + tmp);
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw CloudFileError("cloud: cannot rename " + tmp + " to " + path + ": " + ec.message());
}

}  // namespace mlp::probe_fw
