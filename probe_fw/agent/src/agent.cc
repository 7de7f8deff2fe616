#include "mlp/probe_fw/agent.h"

#include "mlp/probe_fw/cli.h"
#include "mlp/probe_fw/fw_command.h"
#include "mlp/probe_fw/triangulate.h"

#include <chrono>
#include <utility>

namespace mlp::probe_fw {
namespace {

std::int64_t WallClockNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

constexpr link::Millis kPoll{50};

}  // namespace

ProbeAgent::ProbeAgent(ProbeModel model, link::ProbeLink* link, Camera camera, link::Log log)
    : model_(std::move(model)), link_(link), camera_(std::move(camera)), log_(std::move(log)) {}

link::LinkCloud ProbeAgent::Capture(const link::CaptureRequest& request) const {
  link::LinkCloud out;
  out.first_frame_ns = WallClockNs();  // the acquisition starts as the camera is armed
  std::unique_ptr<FrameSource> source = camera_(request);
  std::optional<Frame> led;
  std::vector<Frame> laser;
  Frame f;
  while (source->Next(&f)) {
    if (f.laser_column < 0.0) {
      led = std::move(f);
    } else {
      laser.push_back(std::move(f));
    }
  }
  out.last_frame_ns = WallClockNs();
  if (laser.empty()) throw FrameIoError("the camera delivered no laser frame");
  const RowMask mask = ParseRoi(request.roi, laser.front().aoi, led ? &*led : nullptr);
  StripeCounts counts;
  const std::vector<CloudPoint> cloud = ReconstructSweep(model_, laser, mask, {}, &counts);
  out.capture_id = request.capture_id;
  out.probe_serial = model_.serial;
  out.calibration_id = model_.calibration_id;
  out.mcs_from_flange = request.mcs_from_flange;
  out.xyz.reserve(3 * cloud.size());
  out.quality.reserve(cloud.size());
  for (const CloudPoint& p : cloud) {
    for (int a = 0; a < 3; ++a) out.xyz.push_back(p.point_in_probe(a));
    out.quality.push_back(static_cast<float>(p.quality));
  }
  out.processed_ns = WallClockNs();
  return out;
}

void ProbeAgent::Handle(const link::CaptureRequest& request) {
  using link::ProbeErrorCode;
  try {
    const link::LinkCloud cloud = Capture(request);
    // Counted before the link can deliver it, so that whoever sees the cloud sees it counted;
    // taken back if the link refuses it.
    ++captures_;
    points_ += cloud.size();
    const link::SubmitResult result = link_->Submit(cloud);
    if (result == link::SubmitResult::kQueued) {
      log_("capture " + request.capture_id + ": " + std::to_string(cloud.size()) + " points");
      return;
    }
    --captures_;
    points_ -= cloud.size();
    ++refused_;
    if (result == link::SubmitResult::kBufferFull) {
      link_->ReportError({ProbeErrorCode::kBufferFull, request.capture_id,
                          "the store-and-forward buffer filled during the capture"});
    } else {
      link_->ReportError({ProbeErrorCode::kBadRequest, request.capture_id,
                          "a cloud of this capture id waits for the host already"});
    }
  } catch (const cli::UsageError& e) {
    ++failed_;
    link_->ReportError({ProbeErrorCode::kBadRequest, request.capture_id, e.what()});
  } catch (const std::exception& e) {
    // Camera faults, and a reconstruction that cannot produce a cloud the link can carry.
    ++failed_;
    link_->ReportError({ProbeErrorCode::kCaptureFailed, request.capture_id, e.what()});
  }
}

void ProbeAgent::Serve(const std::atomic<bool>& stop) {
  while (!stop) {
    const std::optional<link::CaptureRequest> request = link_->NextRequest(kPoll);
    if (request) Handle(*request);
  }
}

AgentStats ProbeAgent::Stats() const { return {captures_, points_, refused_, failed_}; }

}  // namespace mlp::probe_fw
