#pragma once
/// @file Frames of one capture, one at a time: a capture directory (recorded frames), or frames
/// in memory (a sweep the board's camera took: sweep.h; a capture the virtual probe rendered).

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/frame_io.h"

#include <memory>
#include <string>
#include <vector>

namespace mlp::probe_fw {

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The next frame of the capture; false after the last one. Throws FrameIoError on failure.
  virtual bool Next(Frame* frame) = 0;
  virtual CaptureMeta Meta() const = 0;
};

/// Frames listed in <dir>/frames.json, read one at a time.
std::unique_ptr<FrameSource> OpenDirectorySource(const std::string& dir);

/// Frames already in memory (a sweep just taken, a rendered capture), in their order.
std::unique_ptr<FrameSource> MakeFrameList(std::vector<Frame> frames, CaptureMeta meta);

}  // namespace mlp::probe_fw
