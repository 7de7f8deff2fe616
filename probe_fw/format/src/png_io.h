#pragma once
// Grey PNG images (8 or 16 bit) read and written through libpng; frame_io.cc chooses by
// extension. Throw FrameIoError naming the file and libpng's reason.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/frame_io.h"

#include <string>

namespace mlp::probe_fw {

/// Pixels, width and height from the file; bit_depth set to 8 for an 8-bit file and left as
/// it is for a 16-bit one (the capture manifest says how many of the 16 bits are used).
void ReadPng(const std::string& path, Frame* frame, const ChannelWeights& channels);
/// 16-bit samples when bit_depth > 8, else 8-bit.
void WritePng(const Frame& frame, const std::string& path);

}  // namespace mlp::probe_fw
