#pragma once
/// @file The relocate job (docs/HOSTD.md `{"op": "relocate"}`, seed 000 example 6), typed: an
/// EDM electrode put back after re-clamping, found again from its surface texture against the
/// texture recorded before it was taken out (toolcam/relocate.h) -> its tool table offsets X, Y
/// (across the spindle), Z (its length) and C (its turn), and what must stop the write (a tilt
/// no four-axis machine corrects; a turn without a C axis; a change beyond the limits).
///
/// The chuck frame's x and y at C = 0 are the machine's X and Y (the reflected-light camera
/// looks along the machine's +X at C = 0: its installation). LinuxCNC's tool offsets are the
/// spindle less the tool's controlled point (its Z the length), so an electrode whose end moved
/// by (dx, dy, dz) and turned by dc gets X - dx, Y - dy, Z - dz, C - dc.

#include "mlp/jobs/request_error.h"
#include "mlp/nc/nc_output.h"
#include "mlp/toolcam/relocate.h"
#include "mlp/toolcam/tool_model.h"

#include <cstdint>
#include <string>
#include <vector>

namespace mlp::jobs {

/// Images of the electrode's faces at the C axis' turns, through one camera.
struct TextureFrames {
  std::vector<std::vector<std::uint8_t>> pixels;
  std::vector<double> turn_deg;  ///< each frame's
  toolcam::ToolCameraModel camera;
};

/// The tilt (and, without a C axis, the turn) no offset corrects, by default: 1.7 um over a
/// 10 mm electrode's height.
inline constexpr double kDefaultMaxTiltDeg = 0.01;

struct RelocateInputs {
  toolcam::ToolDescription electrode;
  int tool_number = 0;
  double max_tilt_deg = kDefaultMaxTiltDeg;
  TextureFrames reference, now;
};

/// The machine as the relocation needs it.
struct RelocateMachine {
  std::string axes =
      "XYZ";                ///< the controller's axes: an offset of an axis it lacks is not written
  bool tool_table = false;  ///< LinuxCNC's tool table takes X, Y and C offsets; others do not
  double max_offset_change_mm = 0.2;
  double max_rotation_change_deg = 1.0;
};

/// Throws RequestError unless `tool` is an electrode (checked before its images are read).
void CheckElectrode(const toolcam::ToolDescription& tool);

/// Finds the electrode again. Throws RequestError (not an electrode; textures that cannot be
/// compared) and toolcam's errors.
toolcam::Relocation AssessRelocate(const RelocateInputs& inputs);

/// The offsets' changes (length, X, Y, C: minus the electrode's motion) for the registers the
/// machine has, before they are resolved against the controller (the caller's
/// ResolveToolChange fills in the values before).
struct OffsetChangeAsked {
  nc::ToolRegister reg;
  double change;  ///< mm, or deg for C
};
std::vector<OffsetChangeAsked> RelocateChangesAsked(const toolcam::Relocation& r,
                                                    const RelocateMachine& machine);

/// The result for the controller: the resolved changes, #<_mlp_status> and #<_mlp_tilt_deg>.
nc::NcResult RelocateChanges(const RelocateInputs& inputs,
                             const toolcam::Relocation& r,
                             std::int64_t job,
                             std::vector<nc::ToolOffsetChange> resolved);

/// What must stop the write: a control without the table's X, Y, C; the tilt over the limit;
/// a turn over it without a C axis; a change beyond the machine's limits (a wrong electrode or
/// tool number).
std::vector<std::string> RelocateRefusal(const RelocateInputs& inputs,
                                         const toolcam::Relocation& r,
                                         const nc::NcResult& changes,
                                         const RelocateMachine& machine);

}  // namespace mlp::jobs
