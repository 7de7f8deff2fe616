#include "mlp/service/capture_broker.h"

#include <algorithm>
#include <condition_variable>
#include <map>
#include <mutex>
#include <string>

namespace mlp::service {

// One waiting job per capture id: the probe asked and the request's H; the link's thread fills
// in the answer.
struct Pending {
  std::string serial;
  Eigen::Isometry3d mcs_from_flange = Eigen::Isometry3d::Identity();
  std::optional<link::LinkCloud> cloud;
  std::optional<link::ProbeError> error;
};

// The probe echoes the request's H as the same 16 doubles; anything else is not this capture.
// Tolerances far below any machine's resolution, above a re-normalisation's rounding.
constexpr double kEchoTolMm = 1e-9, kEchoTolRotation = 1e-12;

bool SamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).cwiseAbs().maxCoeff() <= kEchoTolMm &&
         (a.linear() - b.linear()).cwiseAbs().maxCoeff() <= kEchoTolRotation;
}

struct CaptureBroker::Impl {
  link::Log log;
  std::mutex m;
  std::condition_variable cv;
  std::map<std::string, Pending> pending;  // by capture id
  bool stopping = false;                   // guarded by m
  std::unique_ptr<link::HostLink> host;

  void OnCloud(const link::LinkCloud& c) {
    std::lock_guard lock(m);
    const auto it = pending.find(c.capture_id);
    if (it == pending.end()) {
      log("capture " + c.capture_id + " from " + c.probe_serial +
          " arrived with no job waiting for it (timed out or resent): dropped");
      return;
    }
    it->second.cloud = c;
    cv.notify_all();
  }

  // Before the link decodes a cloud: only the capture a job waits for, from the probe it asked,
  // with the H it sent. A cloud with another H fails that job at once (it would otherwise be
  // measured with the probe's H, or wait out its timeout).
  std::string Admit(const std::string& serial, const link::CloudHeader& head) {
    std::lock_guard lock(m);
    const auto it = pending.find(head.meta.capture_id);
    if (it == pending.end())
      return "no job waits for this capture id (timed out, resent after a restart, or never "
             "asked)";
    Pending& p = it->second;
    if (p.serial != serial) return "that capture was asked of probe " + p.serial;
    if (p.cloud || p.error) return "that capture is answered already";
    if (!SamePose(head.meta.mcs_from_flange, p.mcs_from_flange)) {
      const double off_mm =
          (head.meta.mcs_from_flange.translation() - p.mcs_from_flange.translation()).norm();
      p.error = link::ProbeError{link::ProbeErrorCode::kCaptureFailed, head.meta.capture_id,
                                 "the cloud carries another pose H than the request's (" +
                                     std::to_string(off_mm) +
                                     " mm apart): not measured, take the capture again"};
      cv.notify_all();
      return "its pose H is not the request's";
    }
    return {};
  }

  void OnError(const std::string& serial, const link::ProbeError& e) {
    std::lock_guard lock(m);
    const auto it = pending.find(e.capture_id);
    // The link logged it already; an error from another probe does not end this capture.
    if (it == pending.end() || it->second.serial != serial) return;
    it->second.error = e;
    cv.notify_all();
  }
};

CaptureBroker::CaptureBroker(link::HostLinkConfig config, const link::Log& log)
    : impl_(std::make_unique<Impl>()) {
  impl_->log = log;
  impl_->host = std::make_unique<link::HostLink>(
      std::move(config), [this](const link::LinkCloud& c) { impl_->OnCloud(c); }, log);
  impl_->host->OnError(
      [this](const std::string& s, const link::ProbeError& e) { impl_->OnError(s, e); });
  impl_->host->SetAdmission([this](const std::string& serial, const link::CloudHeader& head) {
    return impl_->Admit(serial, head);
  });
}

CaptureBroker::~CaptureBroker() { Stop(); }

void CaptureBroker::Start() { impl_->host->Start(); }
void CaptureBroker::FailWaiting() {
  std::lock_guard lock(impl_->m);
  impl_->stopping = true;
  impl_->cv.notify_all();
}
void CaptureBroker::Stop() { impl_->host->Stop(); }
std::uint16_t CaptureBroker::Port() const { return impl_->host->Port(); }

std::vector<std::string> CaptureBroker::ConnectedProbes() const {
  return impl_->host->ConnectedProbes();
}

std::optional<link::ProbeStatus> CaptureBroker::LatestStatus(const std::string& serial) const {
  return impl_->host->LatestStatus(serial);
}

link::LinkCloud CaptureBroker::Capture(const std::string& serial,
                                       const link::CaptureRequest& request,
                                       std::chrono::milliseconds timeout) {
  Impl& s = *impl_;
  {
    std::lock_guard lock(s.m);
    if (s.stopping)
      throw CaptureError(CaptureError::Kind::kBadRequest, "the host is stopping: no capture");
    if (!s.pending.emplace(request.capture_id, Pending{serial, request.mcs_from_flange, {}, {}})
             .second)
      throw CaptureError(CaptureError::Kind::kBadRequest,
                         "capture id " + request.capture_id + " is already in flight");
  }
  // Whatever happens, the id stops being awaited when this call returns.
  struct Forget {
    Impl& s;
    const std::string& id;
    ~Forget() {
      std::lock_guard lock(s.m);
      s.pending.erase(id);
    }
  } forget{s, request.capture_id};
  bool sent = false;
  try {
    sent = s.host->RequestCapture(serial, request);
  } catch (const link::LinkError& e) {
    throw CaptureError(CaptureError::Kind::kBadRequest,
                       std::string("capture request refused: ") + e.what());
  }
  if (!sent)
    throw CaptureError(CaptureError::Kind::kProbeNotConnected,
                       "probe " + serial + " is not connected to the host");
  std::unique_lock lock(s.m);
  Pending& p = s.pending.at(request.capture_id);
  // A probe that drops off the link keeps its cloud and resends it when it is back (a Wi-Fi
  // glitch costs no capture), so a drop is waited out up to the timeout like a slow capture.
  if (!s.cv.wait_for(lock, timeout, [&] { return p.cloud || p.error || s.stopping; })) {
    lock.unlock();
    const auto on_link = s.host->ConnectedProbes();
    const bool connected = std::find(on_link.begin(), on_link.end(), serial) != on_link.end();
    const std::string within = " within " + std::to_string(timeout.count()) + " ms";
    throw CaptureError(
        CaptureError::Kind::kTimeout,
        connected
            ? "probe " + serial + " sent no cloud for capture " + request.capture_id + within
            : "probe " + serial + " dropped off the link during capture " + request.capture_id +
                  " and was not back" + within + ": take the capture again");
  }
  if (!p.cloud && !p.error)
    throw CaptureError(CaptureError::Kind::kTimeout,
                       "the host is stopping: capture " + request.capture_id + " abandoned");
  if (p.error)
    throw CaptureError(
        CaptureError::Kind::kProbeError,
        "probe " + serial + ": " + link::ToString(p.error->code) + ": " + p.error->message);
  return std::move(*p.cloud);
}

}  // namespace mlp::service
