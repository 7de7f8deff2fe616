#pragma once
/// @file A cloud as a file: binary little-endian PLY with float x y z [mm, probe frame unless the
/// file names another: a robot's base frame for clouds mapped through a hand-eye] and float
/// quality (0..1); probe serial, calibration id, capture id and (when known) the flange pose H and
/// the LED frame's edge in comments. Float keeps 8 nm at 120 mm, below any probe's resolution, and
/// PCL and `mlp fit` read it. Written by the firmware (`mlp-fw run`) and by the host, which keeps
/// every cloud a job used.

#include "mlp/base/edge_sight.h"
#include "mlp/base/input_error.h"

#include <array>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace mlp::probe_fw {

class CloudFileError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct CloudFileMeta {
  std::string probe_serial, calibration_id, capture_id;
  std::optional<Eigen::Isometry3d> mcs_from_flange;  ///< H (a comment of 16 numbers row by row)
  std::string frame = "probe";  ///< the frame x y z are in: "probe" or "base" (a robot's)
  /// The LED frame's straight edge of an edge ROI (a comment of its 10 numbers and point count)
  std::optional<base::EdgeSight> edge;
};

/// `xyz`: 3 numbers per point; `quality`: one per point. Writes atomically (temporary file +
/// rename). Throws CloudFileError (sizes differ, cannot write).
void WriteCloudPly(const std::string& path,
                   const std::vector<double>& xyz,
                   const std::vector<float>& quality,
                   const CloudFileMeta& meta);

struct CloudFile {
  CloudFileMeta meta;
  std::vector<double> xyz;
  std::vector<float> quality;
};

/// Reads a file WriteCloudPly wrote (its exact header; other PLY files go through the host's
/// general reader). Throws CloudFileError naming what does not match.
CloudFile ReadCloudPly(const std::string& path);

}  // namespace mlp::probe_fw
