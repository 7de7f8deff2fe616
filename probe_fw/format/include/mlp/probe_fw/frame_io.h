#pragma once
/// @file Frames on disk: single images (PGM written and read by hand, 8 or 16 bit; PNG through
/// libpng, grey or colour; BMP read by hand, grey or colour; raw Bayer mosaics) and a capture
/// directory: `frames.json` (format mlprobe-frames/1,
/// docs/PROBE.md) listing each image with its AOI, projector column and, for a colour camera, the
/// weights of its channels.

#include "mlp/base/input_error.h"
#include "mlp/probe_fw/frame.h"

#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace mlp::probe_fw {

class FrameIoError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// How a colour image becomes the one value per pixel the firmware works on: v = r R + g G + b B,
/// clamped to [0, 2^bit_depth - 1]. A red laser on a grey board is r = 1, g = -1 (the board's
/// texture cancels, the laser stays); the board's view under white light is the luminance
/// (0.299, 0.587, 0.114). A pixel where a channel of positive weight reaches full scale is full
/// scale: the stripe extractor must see a clipped laser as saturated whatever the weighting.
struct ChannelWeights {
  bool given = false;  ///< false: colour images are refused (the manifest must say)
  double r = 0.0, g = 0.0, b = 0.0;
};

/// The layout of a raw Bayer frame (`.raw`): the sensor's samples row by row, 1 byte each up
/// to 8 bits, else 2 bytes little-endian, no header.
struct RawBayer {
  bool given = false;
  std::string pattern;  ///< the top-left 2 x 2 cell: "RGGB", "BGGR", "GRBG" or "GBRG"
  int width = 0, height = 0;
  int bit_depth = 8;  ///< 8..16
};
/// Parses {"pattern", "width", "height", "bit_depth"}; throws FrameIoError naming `where`.
RawBayer ParseRawBayer(const nlohmann::json& j, const std::string& where);

/// Writes .pgm (binary P5; maxval 2^bit_depth - 1, 16-bit big-endian above 8 bits) or .png
/// (8 or 16 bit, the value range unchanged), chosen by the extension.
void WriteImage(const Frame& frame, const std::string& path);
/// Reads the pixels of a .pgm, .png, .bmp or .raw into `frame` (AOI size from the image; offset
/// unchanged). A colour image (PNG: RGB, RGBA, palette, 8 or 16 bit; BMP: 24 or 32 bit, or a
/// colour palette) needs `channels` given; a grey one ignores them. A .raw frame needs `raw`
/// and `channels` (demosaiced, then weighed).
void ReadImage(const std::string& path,
               Frame* frame,
               const ChannelWeights& channels = {},
               const RawBayer& raw = {});

struct CaptureMeta {
  std::string probe_serial;
  std::string calibration_id;
  std::string capture_id;
};

/// Writes every frame as <dir>/led.<ext>, <dir>/laser_NNNN.<ext> and the manifest.
void WriteCaptureDir(const std::string& dir,
                     const CaptureMeta& meta,
                     const std::vector<Frame>& frames,
                     const std::string& extension);
/// Reads the manifest; frames are loaded lazily by the directory frame source.
struct CaptureManifest {
  CaptureMeta meta;
  struct Entry {
    std::string file;  ///< relative to the directory
    double laser_column = -1.0;
    Aoi aoi;
    int bit_depth = 8;
    ChannelWeights channels;  ///< "channels": {"r": .., "g": .., "b": ..}, optional
    RawBayer raw;             ///< "raw": {...}, for a .raw file
  };
  std::vector<Entry> frames;
};
CaptureManifest ReadCaptureManifest(const std::string& dir);

}  // namespace mlp::probe_fw
