#pragma once
/// @file A touch probe's trigger related to the tools' positions (seed 000 Fig. 6/7, claims
/// 66-70): the probe's stylus, idle in the spindle, imaged by the tool camera (its ball's
/// centre and radius from the silhouette); then the glass block brought into the view, the
/// probe moved down against its face until it triggers and the machine stops: the camera finds
/// the face. Both frames go through the camera's calibration with the encoders' positions (the
/// frame loop), so the tool frame is where the undeflected stylus stands in each: the face's
/// height above the undeflected ball's bottom is the pretravel, and the gauge point's distance
/// to the face at the trigger is the length a probing cycle must use (the idle length less the
/// pretravel). Sideways the same (the seed shows only the axial case; the block's side face
/// is this project's extension): the probe moved across against a side face of the block
/// standing along the spindle until it triggers; the face's distance from the undeflected
/// ball's centre is the ball's effective radius in a probing cycle, r less the lateral
/// pretravel.

#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"

#include <cstdint>
#include <optional>
#include <vector>

namespace mlp::toolcam {

/// The stylus ball in the tool frame [mm].
struct StylusSeen {
  double centre_y_mm = 0.0, centre_h_mm = 0.0, radius_mm = 0.0;
  double rms_mm = 0.0;  ///< of the outline about the circle
  int points = 0;
};

/// The ball in frames of the idle stylus (not turning): a circle fitted to its silhouette's
/// outline below the stem, every frame's points together. Throws ToolError when the frames do
/// not show it, ToolInputError for a description that is not a stylus.
StylusSeen MeasureStylus(const std::vector<std::vector<std::uint8_t>>& frames,
                         const ToolCameraModel& camera,
                         const ToolDescription& stylus);

/// The glass block's face in frames where it is in view: a line fitted to each column's first
/// fall from the light, away from the stylus (beyond its ball by `clear_mm`); its height at
/// the spindle axis (y = 0) in the tool frame [mm]. Throws ToolError when it does not show.
double MeasureGlassFace(const std::vector<std::vector<std::uint8_t>>& frames,
                        const ToolCameraModel& camera,
                        const ToolDescription& stylus,
                        double clear_mm = 0.1);

struct TriggerCalibration {
  StylusSeen idle;
  double face_h_mm = 0.0;          ///< the face, in the trigger frames' tool frame
  double pretravel_mm = 0.0;       ///< the face above the undeflected ball's bottom
  double idle_length_mm = 0.0;     ///< gauge point to the idle ball's bottom
  double trigger_length_mm = 0.0;  ///< gauge point to the face at the trigger: the tool table's
  double ball_diameter_mm = 0.0;
};

/// `idle` frames through `idle_camera`, `trigger` frames (the block in view, the machine stopped
/// at the trigger) through `trigger_camera`, each the calibration's camera for the stylus'
/// length at that series' spindle position. Throws as above, and ToolError for a pretravel
/// outside [0, 1] mm (the frames are not of one probe, or the face is not the one touched).
TriggerCalibration CalibrateTrigger(const std::vector<std::vector<std::uint8_t>>& idle,
                                    const ToolCameraModel& idle_camera,
                                    const std::vector<std::vector<std::uint8_t>>& trigger,
                                    const ToolCameraModel& trigger_camera,
                                    const ToolDescription& stylus);

/// The block's side face (standing along the spindle axis) in frames where the probe was moved
/// across against it until it triggered: a line fitted to the face's edge farther than the
/// idle ball's radius and `clear_mm` from its centre (the ball, pushed back by a pretravel under
/// `clear_mm`, stays inside; at its height its shadow meets the face) and beyond the stem; its y
/// at the idle ball centre's height in the tool frame [mm]. Throws ToolError when it does not
/// show or does not stand along the axis.
double MeasureGlassSide(const std::vector<std::vector<std::uint8_t>>& frames,
                        const ToolCameraModel& camera,
                        const ToolDescription& stylus,
                        const StylusSeen& idle,
                        double clear_mm = 0.05);

struct LateralTrigger {
  int side = 1;                      ///< +1: the face on the +y side of the ball
  double face_y_mm = 0.0;            ///< at the idle ball centre's height, trigger frames' frame
  double pretravel_mm = 0.0;         ///< the undeflected ball's side beyond the face
  double effective_radius_mm = 0.0;  ///< the idle ball's centre to the face: r less pretravel
};

/// The lateral trigger against `idle` (the ball measured idle, MeasureStylus), `trigger` frames
/// through `trigger_camera` (the calibration's camera at that series' spindle position).
/// Throws as above, and ToolError for a pretravel outside [0, 0.05] mm (MeasureGlassSide's
/// clearance: a probe that travels farther is not one this measures).
LateralTrigger CalibrateLateralTrigger(const StylusSeen& idle,
                                       const std::vector<std::vector<std::uint8_t>>& trigger,
                                       const ToolCameraModel& trigger_camera,
                                       const ToolDescription& stylus);

/// The diameter a probing cycle uses sideways: from faces on both sides, their distance (free of
/// the ball's offset from the spindle axis); from one, twice its effective radius. Throws
/// ToolInputError for none, more than two, or two on one side.
double EffectiveDiameter(const std::vector<LateralTrigger>& sides);

}  // namespace mlp::toolcam
