#pragma once
/// @file Images of a fixed chessboard taken by a camera + line laser on a robot, with the robot's
/// pose for each image (issue 18). A manifest `mlprobe-robot-views/1` says where the images and
/// the poses are and how to read them; nothing about a pose file is guessed in code:
///
///   {"format": "mlprobe-robot-views/1",
///    "images": "blaser",                        folder of the images, relative to the manifest
///    "board": {"inner_cols": 9, "inner_rows": 6, "square_mm": 5},
///    "channels": {"board": {"r": 0.299, "g": 0.587, "b": 0.114},   grey for the board's corners
///                 "laser": {"r": 1, "g": -1, "b": 0}},              the light of a red laser
///    "stripe": {"max_width_px": 30, "window_half_px": 10, "min_amplitude_dn": 20,
///               "speckle_sigma_px": 3},        optional (probe_fw/stripe.h, StripeOptions)
///    "raw": {"pattern": "RGGB", "width": 1280, "height": 960, "bit_depth": 12},
///                                               optional: the images are raw Bayer mosaics
///                                               (probe_fw/frame_io.h, RawBayer)
///    "poses": {"file": "blaser/data.txt",       relative to the manifest
///              "layout": "position-quaternion-name",
///              "position_unit": "m",            "m" or "mm"
///              "quaternion_order": "xyzw",      "xyzw" or "wxyz"
///              "pose": "base_from_flange"}}     or "flange_from_base"
///
/// Layout "position-quaternion-name": three lines per image, `[x, y, z]`, `[q, q, q, q]` in the
/// order given, and the image's file name (without an extension `.png` is added, `.raw` for raw
/// frames; `.bmp` and `.pgm` are read too); blank lines are skipped.

#include "mlp/calib/camera_calib.h"
#include "mlp/geometry/types.h"
#include "mlp/probe_fw/frame_io.h"

#include <string>
#include <vector>

namespace mlp::calib {

/// The stripe extractor's settings for this sensor's stripe (probe_fw/stripe.h): a defocused
/// stripe is wider than a probe's.
struct StripeSettings {
  int max_width_px = 12;
  int window_half_px = 4;
  double min_amplitude_dn = 20.0;
  double speckle_sigma_px = 0.0;  ///< Gaussian smoothing before the scans (stripe.h)
};

struct RobotImage {
  std::string name;  ///< as in the poses file
  std::string path;
  geometry::Pose3 base_from_flange = geometry::Pose3::Identity();  ///< [mm]
};

struct RobotViews {
  ChessboardSpec board;
  probe_fw::ChannelWeights board_channels, laser_channels;
  StripeSettings stripe;
  probe_fw::RawBayer raw;  ///< given: the images are raw Bayer mosaics of this layout
  std::vector<RobotImage> images;
};

/// Throws CaptureIoError naming the manifest field or the pose file's line.
RobotViews LoadRobotViews(const std::string& manifest_path);

}  // namespace mlp::calib
