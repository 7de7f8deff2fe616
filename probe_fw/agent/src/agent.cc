#include "mlp/probe_fw/agent.h"

#include "mlp/probe_fw/cloud_io.h"
#include "mlp/probe_fw/roi_spec.h"
#include "mlp/probe_fw/triangulate.h"

#include <algorithm>
#include <chrono>
#include <thread>
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

SweepPlan PlanSweep(const link::CaptureRequest& r) {
  SweepPlan plan;
  plan.aoi = {r.aoi_x0, r.aoi_y0, r.aoi_width, r.aoi_height};
  plan.exposure_us = r.exposure_us;
  if (!(r.column_step > 0.0) || r.last_column < r.first_column) {
    throw RequestError("the sweep needs first_column <= last_column and column_step > 0");
  }
  // The link bounds the frame count (kMaxSweepFrames); the renderer numbers columns the same way.
  const auto steps = static_cast<size_t>((r.last_column - r.first_column) / r.column_step + 1e-9);
  for (size_t i = 0; i <= steps; ++i) {
    plan.columns.push_back(r.first_column + static_cast<double>(i) * r.column_step);
  }
  return plan;
}

ProbeAgent::ProbeAgent(
    ProbeModel model, link::ProbeLink* link, Camera camera, Projector* projector, link::Log log)
    : model_(std::move(model)),
      link_(link),
      camera_(std::move(camera)),
      projector_(projector),
      log_(std::move(log)) {}

link::LinkCloud ProbeAgent::Capture(const link::CaptureRequest& request) {
  link::LinkCloud out;
  const SweepPlan plan = PlanSweep(request);
  if (plan.columns.back() > projector_->MaxColumn()) {
    throw RequestError("the sweep reaches column " + std::to_string(plan.columns.back()) +
                       "; the mirror reaches " + std::to_string(projector_->MaxColumn()));
  }
  out.first_frame_ns = WallClockNs();  // the acquisition starts as the camera is armed
  std::unique_ptr<FrameGrabber> camera = camera_(request, plan);
  std::vector<Frame> frames;
  try {
    frames = TakeSweep(*projector_, *camera, plan);
  } catch (...) {
    dropped_ += camera->Dropped();
    throw;
  }
  dropped_ += camera->Dropped();
  out.last_frame_ns = WallClockNs();
  const std::vector<Frame> laser(std::make_move_iterator(frames.begin() + 1),
                                 std::make_move_iterator(frames.end()));
  const RoiFound roi = LocateRoi(request.roi, laser.front().aoi, &frames.front());
  StripeCounts counts;
  const std::vector<CloudPoint> cloud = ReconstructSweep(model_, laser, roi.mask, {}, &counts);
  if (roi.edge) out.edge = SightOfEdge(model_.camera, *roi.edge);
  out.stripes = {cloud.size(),
                 counts.weak,
                 counts.cut,
                 counts.saturated,
                 counts.double_peak,
                 counts.too_wide,
                 counts.too_narrow,
                 counts.indirect,
                 counts.second_on_line,
                 counts.undecided_on_line,
                 counts.beside_rejected,
                 counts.reflectance_dropped,
                 counts.isolated};
  out.capture_id = request.capture_id;
  out.probe_serial = model_.serial;
  out.calibration_id = model_.calibration_id;
  out.mcs_from_flange = request.mcs_from_flange;
  PackedCloud packed = PackCloud(cloud);
  out.xyz = std::move(packed.xyz);
  out.quality = std::move(packed.quality);
  out.processed_ns = WallClockNs();
  return out;
}

void ProbeAgent::Fail(link::ProbeErrorCode code,
                      const std::string& capture_id,
                      const std::string& why) {
  last_error_ = static_cast<std::uint16_t>(code);
  link_->ReportError({code, capture_id, why});
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
      Fail(ProbeErrorCode::kBufferFull, request.capture_id,
           "the store-and-forward buffer filled during the capture");
    } else {
      Fail(ProbeErrorCode::kBadRequest, request.capture_id,
           "a cloud of this capture id waits for the host already");
    }
  } catch (const std::invalid_argument& e) {  // RequestError, RoiError: the request
    ++failed_;
    Fail(ProbeErrorCode::kBadRequest, request.capture_id, e.what());
  } catch (const std::exception& e) {
    // Camera and projector faults, and a reconstruction that cannot produce a cloud the link
    // can carry.
    ++failed_;
    Fail(ProbeErrorCode::kCaptureFailed, request.capture_id, e.what());
  }
}

void ProbeAgent::Serve(const std::atomic<bool>& stop) {
  while (!stop) {
    const std::optional<link::CaptureRequest> request = link_->NextRequest(kPoll);
    if (request) Handle(*request);
  }
}

AgentStats ProbeAgent::Stats() const {
  return {captures_, points_, refused_, failed_, dropped_, last_error_};
}

AgentStats ServeProbe(const ProbeModel& model,
                      Camera camera,
                      Projector* projector,
                      const ServeOptions& options,
                      const std::atomic<bool>& stop,
                      const link::Log& log) {
  link::ProbeLink link(options.link, log);
  ProbeAgent agent(model, &link, std::move(camera), projector, log);
  link.SetStatusSource([&agent, &options] {
    const AgentStats stats = agent.Stats();
    const BoardReading board = options.board ? options.board(stats) : BoardReading{};
    link::ProbeStatus s;
    s.battery_percent = board.battery_percent;
    s.temperature_c = board.temperature_c;
    s.flags = board.charging ? link::kStatusCharging : 0;
    s.frames_dropped =
        static_cast<std::uint32_t>(std::min<std::uint64_t>(stats.frames_dropped, UINT32_MAX));
    s.last_error = stats.last_error;
    return s;
  });
  link.Start();
  std::atomic<bool> done{false};
  std::thread watcher([&] {
    while (!stop && !done) {
      if (options.max_captures > 0 && agent.Stats().captures >= options.max_captures &&
          link.WaitAllAcknowledged(link::Millis(100)))
        done = true;
      std::this_thread::sleep_for(link::Millis(50));
    }
    done = true;
  });
  agent.Serve(done);
  watcher.join();
  link.Stop();
  AgentStats stats = agent.Stats();
  log("served " + std::to_string(stats.captures) + " captures (" + std::to_string(stats.points) +
      " points), refused " + std::to_string(stats.refused) + ", failed " +
      std::to_string(stats.failed) + ", frames dropped " + std::to_string(stats.frames_dropped) +
      "; " + std::to_string(link.Unacknowledged()) + " clouds not acknowledged");
  return stats;
}

}  // namespace mlp::probe_fw
