#pragma once
/// @file Seed 000's frame loop (Fig. 1a: 24-32-22-12-10-20-18-26-24): the optical detector
/// (24) on its assembly (26) fixed to the machine's structure (18); the spindle support (20)
/// on the structure, moved by encoder 14C; the spindle carriage (10) on the support, moved by
/// encoder 14B; the chuck (12) on the carriage; the tool (22) in the chuck; the reference
/// pattern model (36) of an edge (32) on the tool; and back to the detector through the image
/// (the reference pattern image model, 52). Each link is a 4 x 4 homogeneous transform
/// (geometry::Pose3, parent <- child); the machine's positions (60) enter as the encoders'
/// travels. When the edge is not where the model says, the loop no longer closes; the part
/// change constraint (68) allows only the model's translation in the tool's y and z, and the
/// two knowns of the image (the model image's shift across and up, from the fit) give that
/// change by a 2 x 2 linear system (the "part change" 72).
///
/// Frames: the detector's x along the view (away from the camera), y across the image (its
/// columns), z up (against its rows); the tool's z the spindle axis, up into the spindle, 0 at
/// the nominal tip. The camera is telecentric: a detector point (x, y, z) is seen at
/// (y, z + x tan(pitch)) mm from the detector's origin (tool_camera.h's pitch, a property of
/// the view the measurement models, not a link of the loop).

#include "mlp/geometry/types.h"
#include "mlp/toolcam/tool_camera.h"

namespace mlp::toolcam {

struct FrameLoop {
  geometry::Pose3 structure_from_detector = geometry::Pose3::Identity();  ///< 18 <- 24 (26)
  geometry::Pose3 structure_from_support = geometry::Pose3::Identity();   ///< 18 <- 20, 14C at 0
  geometry::Vec3 support_travel = geometry::Vec3::UnitZ();                ///< 14C's direction in 18
  geometry::Pose3 support_from_carriage = geometry::Pose3::Identity();    ///< 20 <- 10, 14B at 0
  geometry::Vec3 carriage_travel = geometry::Vec3::UnitY();               ///< 14B's direction in 20
  /// 10 <- 12: the chuck's gauge point, its z the spindle axis.
  geometry::Pose3 carriage_from_chuck = geometry::Pose3::Identity();
  double tool_length_mm = 0.0;  ///< 12 <- 22: the nominal tip this far down the spindle axis
  /// 22 <- 36: the reference model's place on the tool, the allowed change (y, z) [mm].
  geometry::Vec2 model_change_mm = geometry::Vec2::Zero();
  double encoder_y_mm = 0.0, encoder_z_mm = 0.0;  ///< the machine's positions (60)

  /// The tool frame in the detector's, round the loop (the model's with its change).
  geometry::Pose3 DetectorFromTool() const;
  geometry::Pose3 DetectorFromModel() const;
};

/// The camera the loop implies for the tool: `base`'s image size, lens, scale and pitch, with
/// the nominal tip's pixel and the spindle axis' roll in the image from the loop; the
/// detector's origin is at pixel (0, 0).
ToolCameraModel CameraThroughLoop(const FrameLoop& loop, const ToolCameraModel& base);

/// The part change that closes the loop again: the model's translation (y, z) in the tool
/// frame when the fit found the model's image moved by `image_shift_mm` (across, up) from
/// where the loop put it. Throws ToolInputError when the loop turns the tool's y-z plane edge
/// on to the view (the change would not show).
geometry::Vec2 AllowedChange(const FrameLoop& loop, const geometry::Vec2& image_shift_mm);

/// How far the loop is from closing [mm]: the image distance between where the loop puts the
/// model's origin and where the image saw it (`seen_px`), at the camera's scale.
double LoopGapMm(const FrameLoop& loop, const ToolCameraModel& base, const geometry::Vec2& seen_px);

}  // namespace mlp::toolcam
