#pragma once
// Windows bitmaps (.bmp) as small industrial cameras save them, and raw Bayer mosaics (.raw) as
// a sensor delivers them; frame_io.cc chooses by extension. Throw FrameIoError naming the file.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/frame_io.h"

#include <string>

namespace mlp::probe_fw {

/// Uncompressed bitmaps: 8 bit with a palette (grey or colour), 24 bit (BGR), 32 bit (BGRA,
/// plain or with the standard bit fields); bottom-up or top-down. A colour image needs
/// `channels` given. bit_depth is 8.
void ReadBmp(const std::string& path, Frame* frame, const ChannelWeights& channels);

/// A Bayer mosaic of `raw.width` x `raw.height` samples, 1 byte each up to 8 bits, else 2 bytes
/// little-endian; demosaiced (OpenCV's bilinear) and weighed by `channels` (required).
/// bit_depth is raw.bit_depth.
void ReadRawBayer(const std::string& path,
                  Frame* frame,
                  const ChannelWeights& channels,
                  const RawBayer& raw);

}  // namespace mlp::probe_fw
