#include "mlp/sim/virtual_source.h"

namespace mlp::sim {
std::unique_ptr<probe_fw::FrameSource> MakeVirtualSource(RenderedCapture capture,
                                                         probe_fw::CaptureMeta meta) {
  std::vector<probe_fw::Frame> frames{std::move(capture.led)};
  for (probe_fw::Frame& f : capture.laser) frames.push_back(std::move(f));
  return probe_fw::MakeFrameList(std::move(frames), std::move(meta));
}

}  // namespace mlp::sim
