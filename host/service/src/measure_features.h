#pragma once
// The features a measure job knows (internal to mlp_service): each parses its nominal from the
// request, measures it from the mapped points (mlp::jobs) and says what the shared decision
// needs: the toleranced size, how its error moves an offset, its numbers for the reply and the
// evidence for the plausibility gate.

#include "mlp/jobs/decision.h"
#include "mlp/jobs/feature.h"
#include "mlp/jobs/plan.h"
#include "mlp/jobs/report.h"

#include <optional>
#include <string>
#include <vector>

#include "job_common.h"
#include <nlohmann/json.hpp>

namespace mlp::service {

struct Measured {
  std::string feature;
  std::string size_name;  ///< the LinuxCNC parameter: #<_mlp_<size_name>>
  std::string unit = "mm";
  double size = 0.0;
  jobs::SizeSpec spec;
  /// Offset change per unit of size error; nullopt: the feature moves no offset (an angle, a
  /// bolt circle, a surface profile), and an update asked for is refused as input.
  std::optional<double> change_per_error;
  /// The offset it moves: a length (a face's height, a step) or else a radius (a size across).
  bool moves_length = false;
  nlohmann::json fields;
  jobs::FitEvidence fe;
  /// Other tolerances of the job that were exceeded (flatness, true position, the second size
  /// of a rectangle): each makes the verdict out of tolerance.
  std::vector<std::string> problems;
  std::optional<jobs::BoreMeasurement> bore;  ///< for the picture: a roundness plot
  std::vector<jobs::DeviationPanel> panels;   ///< for the picture of the others
  /// Where the feature was found and where its nominal put it (a centre, a face's point): a
  /// work offset update moves by the difference. Unset for features without a position.
  std::optional<geometry::Vec3> found_mcs;
  geometry::Vec3 nominal_mcs = geometry::Vec3::Zero();
};

/// Throws JobInputError listing the features known when `feature` is not one of them.
void CheckFeatureName(const std::string& feature);

/// Throws JobInputError (an unknown feature, a field missing or wrong), jobs::FeatureError (not
/// measurable from these points). `data_dir` resolves relative nominal files.
Measured MeasureFeature(const nlohmann::json& request,
                        const Evidence& evidence,
                        const std::string& data_dir);

/// The views a feature's capture plan needs (mlp::jobs plan.h), from the same request.
std::vector<jobs::ViewTarget> FeatureViews(const nlohmann::json& request,
                                           const std::string& data_dir,
                                           const jobs::PlanOptions& options);

}  // namespace mlp::service
