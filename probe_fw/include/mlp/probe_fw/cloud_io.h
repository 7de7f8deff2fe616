#pragma once
/// @file The firmware's cloud as a file: binary little-endian PLY with float x y z [mm, probe
/// frame] and float quality (0..1); probe serial, calibration and capture id in comments. Float
/// keeps 8 nm at 120 mm, below any probe's resolution, and PCL and `mlp fit` read it.

#include "mlp/base/edge_sight.h"
#include "mlp/probe_fw/frame_io.h"
#include "mlp/probe_fw/triangulate.h"

#include <optional>
#include <string>
#include <vector>

namespace mlp::probe_fw {

/// A cloud as the file and the link carry it: x y z per point [mm, probe frame], quality 0..1.
struct PackedCloud {
  std::vector<double> xyz;
  std::vector<float> quality;
};
PackedCloud PackCloud(const std::vector<CloudPoint>& cloud);

/// Writes atomically (temporary file + rename), with the LED frame's edge of an edge ROI when
/// given. Throws FrameIoError.
void WriteCloudPly(const std::string& path,
                   const std::vector<CloudPoint>& cloud,
                   const CaptureMeta& meta,
                   const std::optional<base::EdgeSight>& edge = std::nullopt);

}  // namespace mlp::probe_fw
