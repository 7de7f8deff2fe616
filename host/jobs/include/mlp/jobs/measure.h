#pragma once
/// @file The measure job (docs/HOSTD.md `{"op": "measure"}`), typed: a feature's request and
/// the updates asked for, the evidence gathered for it and the machine's limits -> the
/// readings, the size decision, the verdict, the plausibility gate's refusal and the changes
/// for the controller. The service reads the request's JSON, loads the captures, records the
/// job and writes; everything it decides on is decided here.

#include "mlp/features/decision.h"
#include "mlp/jobs/evidence.h"
#include "mlp/jobs/measure_feature.h"
#include "mlp/jobs/request_error.h"
#include "mlp/nc/nc_output.h"
#include "mlp/nc/offsets.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mlp::jobs {

/// "update": the tool offset the size error moves, and how (feedback %, null band, upper
/// tolerance limit, experience value).
struct ToolUpdateRequest {
  int offset = 0;
  nc::ToolRegister reg = nc::ToolRegister::kRadiusWear;
  features::Feedback feedback;  ///< change_per_error is the feature's (FeedbackFor)
};

/// "update_work": the work offset moved by where the feature was found against its nominal
/// (a part set up on one feature), in the control (incremental).
struct WorkUpdateRequest {
  int offset = 0;
  std::array<bool, 3> axes{};  ///< X Y Z
};

struct MeasureRequest {
  FeatureRequest feature;
  std::optional<ToolUpdateRequest> update;
  std::optional<WorkUpdateRequest> update_work;
  bool report = true;  ///< draw the picture
};

/// The updates asked for, against what the feature can move: a tool offset (its length or its
/// radius) and a work offset (from its position). Throws RequestError.
void CheckUpdatesFit(const MeasureRequest& request);

struct MeasureOutcome {
  Measured measured;
  features::Feedback feedback;  ///< none (report only) or the update asked for
  features::SizeDecision decision;
  /// The work offset change asked for, where the feature was found against its nominal.
  std::optional<nc::WorkOffsetChange> work;
  /// Out of tolerance too when another tolerance of the job is exceeded (flatness, true
  /// position, a rectangle's second size); the reason lists those first.
  bool in_tolerance = false;
  std::string verdict, reason;
  /// The plausibility gate's problems (features::PlausibilityProblems) with every change to be
  /// written: any one means nothing is written.
  std::vector<std::string> refusal;
};

/// measure -> decide -> gate. Throws features::FeatureError (not measurable from these points).
MeasureOutcome AssessMeasure(const MeasureRequest& request,
                             const Evidence& evidence,
                             const CalibrationFacts& calibration,
                             const features::PlausibilityLimits& limits);

/// What goes to the controller: the macro's parameters (`named_parameters`: LinuxCNC's
/// #<_mlp_...>), the tool change `tool` (the decision's change as the controller takes it,
/// resolved against its own state by the caller), the work offset change. Beyond the upper
/// tolerance limit the feature is not what the program expects: no work offset follows it.
nc::NcResult MeasureChanges(const MeasureOutcome& outcome,
                            std::int64_t job,
                            bool named_parameters,
                            const std::optional<nc::ToolOffsetChange>& tool);

/// The picture for the operator (SVG): a bore or boss its roundness plot; the others their
/// surfaces' deviations and the readings, a line each.
std::string MeasureReportSvg(const MeasureOutcome& outcome,
                             const std::string& title,
                             const std::string& time_utc);

}  // namespace mlp::jobs
