#pragma once
/// @file Camera/projector calibration views on disk. A manifest `mlprobe-board-views/1`
///   {"format": "mlprobe-board-views/1",
///    "board": {"inner_cols": 9, "inner_rows": 6, "square_mm": 2.5},
///    "views": ["view01", "view02", ...]}        capture directories, relative to the manifest
/// names capture directories as the probe writes them (`frames.json` + images, docs/PROBE.md),
/// each holding an LED frame of the whole sensor (intrinsics are a property of the whole image)
/// and, for the projector, `stripes.json` (`mlp-fw stripes`: stripe centres with the projector
/// column lit, not triangulated).

#include "mlp/calib/camera_calib.h"
#include "mlp/calib/probe_calib.h"

#include <string>
#include <vector>

namespace mlp::calib {

struct BoardView {
  std::string dir, capture_id;
  GrayImage led;
  std::vector<StripeObservation> stripes;  ///< `view` = index in BoardViews::views
};

struct BoardViews {
  ChessboardSpec board;
  std::string probe_serial;  ///< every view's frames and stripes are from this probe
  std::vector<BoardView> views;
};

/// Throws CaptureIoError naming the manifest entry or file: unreadable, another probe's frames,
/// an LED frame that is not the whole sensor (`sensor_width_px` x `sensor_height_px`, when > 0),
/// views of different sizes, or (with `with_stripes`) a view without stripes.json. A capture
/// folder, image or stripe file that cannot be read throws its reader's own error
/// (probe_fw::FrameIoError, StripeFileError); all are base::InputError.
BoardViews LoadBoardViews(const std::string& manifest_path,
                          bool with_stripes,
                          int sensor_width_px = 0,
                          int sensor_height_px = 0);

}  // namespace mlp::calib
