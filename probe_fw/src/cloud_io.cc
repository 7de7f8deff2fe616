#include "mlp/probe_fw/cloud_io.h"

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
                   const std::vector<CloudPoint>& cloud,
                   const CaptureMeta& meta) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << "ply\nformat binary_little_endian 1.0\n"
        << "comment mlprobe cloud, probe frame, millimetres\n"
        << "comment probe_serial " << OneLine(meta.probe_serial) << "\n"
        << "comment calibration_id " << OneLine(meta.calibration_id) << "\n"
        << "comment capture_id " << OneLine(meta.capture_id) << "\n"
        << "element vertex " << cloud.size() << "\n"
        << "property float x\nproperty float y\nproperty float z\nproperty float quality\n"
        << "end_header\n";
    for (const CloudPoint& p : cloud) {
      PutFloat(out, p.point_in_probe.x());
      PutFloat(out, p.point_in_probe.y());
      PutFloat(out, p.point_in_probe.z());
      PutFloat(out, p.quality);
    }
    if (!out) throw FrameIoError("cloud: cannot write " + tmp);
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace mlp::probe_fw
