#pragma once
/// @file The tool job (docs/HOSTD.md `{"op": "tool"}`, seed 000), typed: a tool measured from
/// the tool camera's frames (one side, both sides, or two cameras), or a touch probe's stylus
/// from its idle and triggered frames -> its length and radius for the tool table, how worn it
/// is, and what must stop the write. The service reads the request and the image folders and
/// writes; everything decided is decided here.

#include "mlp/jobs/readings.h"
#include "mlp/jobs/request_error.h"
#include "mlp/nc/nc_output.h"
#include "mlp/toolcam/measure.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"
#include "mlp/toolcam/two_views.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace mlp::jobs {

/// One series of the tool camera's frames and the camera as it stood for them.
struct ToolFrames {
  std::vector<std::vector<std::uint8_t>> pixels;  ///< one frame each, row-major grey
  std::vector<int> position;                      ///< each frame's strobe position
  int positions = 0;                              ///< strobe positions per turn
  double blur_rad = 0.0;                          ///< the tool's turn during a pulse
  toolcam::ToolCameraModel camera;
};

struct ToolInputs {
  toolcam::ToolDescription tool;         ///< the nominal (or the stylus)
  int tool_number = 0;                   ///< the tool table's
  bool accept_findings = false;          ///< write even beyond the tool's wear limit
  std::optional<double> start_turn_deg;  ///< the chuck's turn at position 0 (an electrode's)
  ToolFrames images;                     ///< a stylus: its idle frames
  std::optional<ToolFrames> other_side;  ///< a wide tool's -y flank
  /// A second camera's frames of the same pulses and its view's angle from the first's.
  std::optional<ToolFrames> second_view;
  toolcam::SecondView mount;
  std::optional<ToolFrames> trigger;      ///< a stylus: its frames at the trigger
  std::vector<ToolFrames> trigger_sides;  ///< a stylus at its lateral trigger (one or two)
};

struct ToolOutcome {
  double length_mm = 0.0, radius_mm = 0.0;  ///< for the tool table
  double worst_finding_mm = 0.0;            ///< or an electrode's worst corner wear, if more
  bool over_wear_limit = false;
  /// What was measured: a cutter from one camera (one side or both), from two cameras, or a
  /// stylus (its readings: ball, pretravel, lengths, lateral triggers).
  std::variant<toolcam::ToolMeasurement, toolcam::ToolIn3d, Readings> measurement;
};

/// Measures the tool. Throws RequestError (frames that do not go together: a second view with
/// another side, a stylus without its trigger frames, two views that disagree with the mount)
/// and toolcam's errors (the frames not showing the tool).
ToolOutcome AssessTool(const ToolInputs& inputs);

/// The tool table's length (Z) and radius (D / 2) of `inputs.tool_number`: `before` holds the
/// two registers (length geometry, radius geometry) as the controller holds them (or 0 where
/// the host cannot read them); the changes written are absolute. `named_parameters`: LinuxCNC's
/// #<_mlp_status>, #<_mlp_length>, #<_mlp_diameter>.
nc::NcResult ToolChanges(const ToolOutcome& outcome,
                         const ToolInputs& inputs,
                         std::int64_t job,
                         bool named_parameters,
                         const std::array<nc::ToolOffsetChange, 2>& before);

/// What must stop the write: wear beyond the tool's limit (unless accepted), and where the
/// controller's values are known (`values_known`: LinuxCNC's table), a change beyond the
/// machine's limit (a wrong tool or number; the diameter to twice the limit).
std::vector<std::string> ToolRefusal(const ToolOutcome& outcome,
                                     const ToolInputs& inputs,
                                     const nc::NcResult& changes,
                                     double max_offset_change_mm,
                                     bool values_known);

}  // namespace mlp::jobs
