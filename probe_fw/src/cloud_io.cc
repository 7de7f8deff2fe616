#include "mlp/probe_fw/cloud_io.h"

#include "mlp/probe_fw/cloud_file.h"

namespace mlp::probe_fw {

void WriteCloudPly(const std::string& path,
                   const std::vector<CloudPoint>& cloud,
                   const CaptureMeta& meta,
                   const std::optional<base::EdgeSight>& edge) {
  std::vector<double> xyz;
  std::vector<float> quality;
  xyz.reserve(3 * cloud.size());
  quality.reserve(cloud.size());
  for (const CloudPoint& p : cloud) {
    xyz.insert(xyz.end(), {p.point_in_probe.x(), p.point_in_probe.y(), p.point_in_probe.z()});
    quality.push_back(static_cast<float>(p.quality));
  }
  WriteCloudPly(path, xyz, quality,
                {meta.probe_serial, meta.calibration_id, meta.capture_id, {}, "probe", edge});
}

}  // namespace mlp::probe_fw
