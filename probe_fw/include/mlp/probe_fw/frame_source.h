#pragma once
/// @file Where frames come from, behind one interface: a capture directory (replay of recorded
/// frames), a Linux V4L2 camera (the real probe), or the virtual probe (mlp/sim/virtual_source.h).

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

/// A V4L2 camera (8-bit GREY or 16-bit Y16, memory-mapped streaming). `laser_columns` holds the
/// projector column the MEMS driver lit for each successive frame (negative: the LED frame);
/// the capture ends after that many frames. Throws FrameIoError naming the device and the
/// reason when there is no such camera or it cannot deliver the format.
std::unique_ptr<FrameSource> OpenV4l2Source(const std::string& device,
                                            const Aoi& aoi,
                                            int bit_depth,
                                            std::vector<double> laser_columns,
                                            CaptureMeta meta);

}  // namespace mlp::probe_fw
