#include "mlp/sim/virtual_source.h"

namespace mlp::sim {
namespace {

class VirtualSource : public probe_fw::FrameSource {
 public:
  VirtualSource(RenderedCapture capture, probe_fw::CaptureMeta meta)
      : capture_(std::move(capture)), meta_(std::move(meta)) {}
  bool Next(probe_fw::Frame* frame) override {
    if (next_ > capture_.laser.size()) return false;
    *frame = next_ == 0 ? capture_.led : capture_.laser[next_ - 1];
    ++next_;
    return true;
  }
  probe_fw::CaptureMeta Meta() const override { return meta_; }

 private:
  RenderedCapture capture_;
  probe_fw::CaptureMeta meta_;
  size_t next_ = 0;
};

}  // namespace

std::unique_ptr<probe_fw::FrameSource> MakeVirtualSource(RenderedCapture capture,
                                                         probe_fw::CaptureMeta meta) {
  return std::make_unique<VirtualSource>(std::move(capture), std::move(meta));
}

}  // namespace mlp::sim
