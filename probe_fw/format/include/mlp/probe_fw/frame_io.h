#pragma once
/// @file Frames on disk: single images (PGM written and read by hand, 8 or 16 bit; PNG through
/// libpng) and a capture directory: `frames.json` (format mlprobe-frames/1, docs/FRAMES.md)
/// listing each image with its AOI and projector column.

#include "mlp/probe_fw/frame.h"

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::probe_fw {

class FrameIoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Writes .pgm (binary P5; maxval 2^bit_depth - 1, 16-bit big-endian above 8 bits) or .png
/// (8 or 16 bit, the value range unchanged), chosen by the extension.
void WriteImage(const Frame& frame, const std::string& path);
/// Reads the pixels of a .pgm or .png into `frame` (AOI size from the image; offset unchanged).
void ReadImage(const std::string& path, Frame* frame);

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
  };
  std::vector<Entry> frames;
};
CaptureManifest ReadCaptureManifest(const std::string& dir);

}  // namespace mlp::probe_fw
