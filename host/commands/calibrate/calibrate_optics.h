#pragma once
// `mlp calibrate camera|projector` (internal to mlp_host_calibrate; calibrate_command.cc
// dispatches here).

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// args[0] is "camera" or "projector". Throws UsageError, calib::CaptureIoError,
/// calib::CameraCalibError, probe_fw::ProbeModelError (RunCalibrateCommand reports them).
int RunCameraProjectorCommand(const std::vector<std::string>& args,
                              std::ostream& out,
                              std::ostream& err);

}  // namespace mlp::host
