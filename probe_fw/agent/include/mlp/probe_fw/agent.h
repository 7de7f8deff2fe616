#pragma once
/// @file The firmware's main loop on the link: take a capture request, have the camera take the
/// sweep (LED frame, then the laser frames), reconstruct the cloud in the requested ROI and hand
/// it to the link's store-and-forward buffer. A request that cannot be carried out is answered
/// with an ERROR naming the reason; the loop never stops on a bad request.

#include "mlp/link/transport.h"
#include "mlp/probe_fw/frame_source.h"
#include "mlp/probe_fw/probe_model.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>

namespace mlp::probe_fw {

/// The hardware side of a capture: frames of the requested sweep at the requested AOI and
/// exposure. Throws FrameIoError when the camera fails, cli::UsageError when the request cannot
/// be met (an AOI outside the sensor, say).
using Camera = std::function<std::unique_ptr<FrameSource>(const link::CaptureRequest& request)>;

struct AgentStats {
  std::uint64_t captures = 0, points = 0, refused = 0, failed = 0;
};

class ProbeAgent {
 public:
  ProbeAgent(ProbeModel model, link::ProbeLink* link, Camera camera, link::Log log);

  /// Serves requests until `stop` is set (checked every 50 ms).
  void Serve(const std::atomic<bool>& stop);
  /// One request's cloud, in the probe frame, carrying the request's id and pose. Throws
  /// cli::UsageError (the request: ROI, AOI) or FrameIoError (the camera).
  link::LinkCloud Capture(const link::CaptureRequest& request) const;
  AgentStats Stats() const;

 private:
  void Handle(const link::CaptureRequest& request);

  ProbeModel model_;
  link::ProbeLink* link_;
  Camera camera_;
  link::Log log_;
  std::atomic<std::uint64_t> captures_{0}, points_{0}, refused_{0}, failed_{0};
};

}  // namespace mlp::probe_fw
