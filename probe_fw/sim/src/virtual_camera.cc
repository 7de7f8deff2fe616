#include "mlp/sim/virtual_camera.h"

#include "mlp/probe_fw/cli.h"
#include "mlp/sim/virtual_source.h"

#include <functional>
#include <stdexcept>

namespace mlp::sim {

Pose3 PoseOf(const std::array<double, 16>& h) {
  Eigen::Matrix4d m;
  for (int k = 0; k < 16; ++k) m(k / 4, k % 4) = h[static_cast<size_t>(k)];
  Pose3 p = Pose3::Identity();
  p.linear() = m.topLeftCorner<3, 3>();
  p.translation() = m.topRightCorner<3, 1>();
  return p;
}

probe_fw::Camera MakeVirtualCamera(std::shared_ptr<const VirtualProbe> probe, std::uint64_t seed) {
  return [probe, seed](const link::CaptureRequest& r) {
    Capture capture;
    capture.id = r.capture_id;
    capture.mcs_from_flange = PoseOf(r.mcs_from_flange);
    SweepOptions o;
    o.aoi = {r.aoi_x0, r.aoi_y0, r.aoi_width, r.aoi_height};
    o.first_column = r.first_column;
    o.last_column = r.last_column;
    o.column_step = r.column_step;
    o.seed = seed ^ std::hash<std::string>{}(r.capture_id);
    RenderedCapture frames;
    try {
      frames = probe->Render(capture, o);
    } catch (const std::invalid_argument& e) {
      throw probe_fw::cli::UsageError(e.what());  // the request, not the camera, is at fault
    }
    probe_fw::CaptureMeta meta{probe->model().serial, probe->model().calibration_id, r.capture_id};
    return MakeVirtualSource(std::move(frames), meta);
  };
}

}  // namespace mlp::sim
