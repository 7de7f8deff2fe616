#pragma once
/// @file The firmware's main loop on the link: take a capture request, sweep (the LED frame,
/// then one laser frame per projector column, the mirror driven by the agent), reconstruct the
/// cloud in the requested ROI and hand it to the link's store-and-forward buffer. A request
/// that cannot be carried out is answered with an ERROR naming the reason; the loop never stops
/// on a bad request. The board's probe (`mlp-fw serve`) and the virtual one (`mlp-sim serve`)
/// are this agent with different cameras and projectors plugged in.

#include "mlp/link/transport.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/projector.h"
#include "mlp/probe_fw/sweep.h"

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>

namespace mlp::probe_fw {

/// A request the camera cannot carry out as given (a window outside the sensor, say): answered
/// ERROR bad_request, not capture_failed.
class RequestError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Arms the camera for one request's sweep. Throws RequestError (the request is at fault) or
/// FrameIoError (the camera is).
using Camera = std::function<std::unique_ptr<FrameGrabber>(const link::CaptureRequest& request,
                                                           const SweepPlan& plan)>;

/// The sweep a request asks for: its window and exposure, columns first + i * step up to last.
SweepPlan PlanSweep(const link::CaptureRequest& request);

struct AgentStats {
  std::uint64_t captures = 0, points = 0, refused = 0, failed = 0;
  std::uint64_t frames_dropped = 0;  ///< by the camera, over all captures
  std::uint16_t last_error = 0;      ///< link::ProbeErrorCode of the last failure, 0: none
};

class ProbeAgent {
 public:
  /// `projector` must outlive the agent.
  ProbeAgent(
      ProbeModel model, link::ProbeLink* link, Camera camera, Projector* projector, link::Log log);

  /// Serves requests until `stop` is set (checked every 50 ms).
  void Serve(const std::atomic<bool>& stop);
  /// One request's cloud, in the probe frame, carrying the request's id and pose. Throws
  /// RequestError or RoiError (the request) or FrameIoError / ProjectorError (the hardware).
  link::LinkCloud Capture(const link::CaptureRequest& request);
  AgentStats Stats() const;

 private:
  void Handle(const link::CaptureRequest& request);
  void Fail(link::ProbeErrorCode code, const std::string& capture_id, const std::string& why);

  ProbeModel model_;
  link::ProbeLink* link_;
  Camera camera_;
  Projector* projector_;
  link::Log log_;
  std::atomic<std::uint64_t> captures_{0}, points_{0}, refused_{0}, failed_{0}, dropped_{0};
  std::atomic<std::uint16_t> last_error_{0};
};

/// What the board reports beside the agent's counts: battery and temperature.
struct BoardReading {
  std::uint8_t battery_percent = 100;
  double temperature_c = 25.0;
  bool charging = false;
};

struct ServeOptions {
  link::ProbeLinkConfig link;
  std::uint64_t max_captures = 0;  ///< stop once this many are acknowledged; 0: run until stop
  std::function<BoardReading(const AgentStats&)> board;
};

/// The probe's life on the link: connect, serve requests, report status (board readings,
/// buffer, frames dropped, last error), until `stop` is set or `max_captures` are
/// acknowledged. Returns the final counts.
AgentStats ServeProbe(const ProbeModel& model,
                      Camera camera,
                      Projector* projector,
                      const ServeOptions& options,
                      const std::atomic<bool>& stop,
                      const link::Log& log);

}  // namespace mlp::probe_fw
