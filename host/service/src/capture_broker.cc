#include "mlp/service/capture_broker.h"

#include <algorithm>
#include <condition_variable>
#include <map>
#include <mutex>

namespace mlp::service {

// One waiting job per capture id; the link's thread fills it in.
struct Pending {
  std::optional<link::LinkCloud> cloud;
  std::optional<link::ProbeError> error;
};

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

  void OnError(const std::string& serial, const link::ProbeError& e) {
    std::lock_guard lock(m);
    const auto it = pending.find(e.capture_id);
    if (it == pending.end()) return;  // the link logged it already
    (void)serial;
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
    if (!s.pending.emplace(request.capture_id, Pending{}).second)
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
