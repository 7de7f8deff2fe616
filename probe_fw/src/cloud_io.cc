#include "mlp/probe_fw/cloud_io.h"

#include "mlp/probe_fw/cloud_file.h"

namespace mlp::probe_fw {

PackedCloud PackCloud(const std::vector<CloudPoint>& cloud) {
  PackedCloud out;
  out.xyz.reserve(3 * cloud.size());
  out.quality.reserve(cloud.size());
  for (const CloudPoint& p : cloud) {
    out.xyz.insert(out.xyz.end(),
                   {p.point_in_probe.x(), p.point_in_probe.y(), p.point_in_probe.z()});
    out.quality.push_back(static_cast<float>(p.quality));
  }
  return out;
}

void WriteCloudPly(const std::string& path,
                   const std::vector<CloudPoint>& cloud,
                   const CaptureMeta& meta,
                   const std::optional<base::EdgeSight>& edge) {
  const PackedCloud packed = PackCloud(cloud);
  WriteCloudPly(path, packed.xyz, packed.quality,
                {meta.probe_serial, meta.calibration_id, meta.capture_id, {}, "probe", edge});
}

}  // namespace mlp::probe_fw
