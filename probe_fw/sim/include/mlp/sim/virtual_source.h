#pragma once
/// @file The virtual probe as a frame source: rendered frames fed in memory straight into the
/// firmware, through the same interface as a camera or a directory.

#include "mlp/probe_fw/frame_source.h"
#include "mlp/sim/render.h"

#include <memory>

namespace mlp::sim {

/// The LED frame first, then the laser frames in sweep order.
std::unique_ptr<probe_fw::FrameSource> MakeVirtualSource(RenderedCapture capture,
                                                         probe_fw::CaptureMeta meta);

}  // namespace mlp::sim
