#pragma once
/// @file Reading hand-eye inputs from disk: the sphere-captures manifest
/// (`mlprobe-sphere-captures/1`, docs/CALIBRATION.md), OpenCV FileStorage profiles (a line
/// scanner's x y z triplets, NaN where it saw nothing) and robot pose lists.

#include "mlp/base/input_error.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/geometry/types.h"

#include <array>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::calib {

class CaptureIoError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// The flat x y z list under `key` of an OpenCV FileStorage file (YAML, XML or JSON), as
/// points [mm]; NaN entries are kept (the fit drops them). Throws CaptureIoError.
geometry::Points3 LoadFileStorageProfile(const std::string& path, const std::string& key);

/// Lines of "x y z w p r" (mm, degrees; R = Rz(r) Ry(p) Rx(w)), one pose per line. Throws
/// CaptureIoError naming the line of anything else.
std::vector<geometry::Pose3> LoadXyzWprPoses(const std::string& path);

/// A sphere hand-eye's captures on disk: the probe, the sphere, what counts as determined, and
/// per capture its id, H (`mcs_from_flange` as a pose, or `mcs_from_flange_xyzwpr`) and its
/// cloud (a path relative to the manifest).
struct SphereCaptureManifest {
  std::string probe_serial;
  double sphere_radius_mm = 0.0;
  std::array<std::optional<double>, 3> known_centre_mcs;  ///< where the sphere is known
  std::optional<double> max_std_mm, lever_mm;
  std::vector<SphereCapture> captures;
};

/// Reads a cloud file that is not a FileStorage profile (.yml/.yaml, read here); the caller
/// knows the cloud formats (the host: .xyz, .pcd, .ply).
using CloudReader = std::function<geometry::Points3(const std::string& path)>;

/// Reads `mlprobe-sphere-captures/1` and every cloud it names; throws CaptureIoError naming
/// the file and the field (a cloud reader's own error passes through).
SphereCaptureManifest LoadSphereCaptureManifest(const std::string& path,
                                                const CloudReader& read_cloud);

}  // namespace mlp::calib
