#pragma once
// The features a measure job knows (internal to mlp_service): each reads its part of the
// request once into a FeatureRequest (nominal, the size decided on, its tolerances), checked
// before any capture is loaded; then measures it from the mapped points (mlp::features) and says
// what the shared decision needs: the toleranced size, its numbers for the reply and the
// evidence for the plausibility gate.

#include "mlp/features/composite.h"
#include "mlp/features/decision.h"
#include "mlp/features/feature.h"
#include "mlp/features/plan.h"
#include "mlp/features/report.h"
#include "mlp/features/surface.h"

#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "job_common.h"
#include <nlohmann/json.hpp>

namespace mlp::service {

/// A feature's nominal (request.feature and request.nominal): what a plan places its views by
/// and a measurement segments the points by.
struct FeatureNominal {
  using Shape = std::variant<features::BoreNominal,
                             features::PlaneNominal,
                             features::WidthNominal,
                             features::RectangleNominal,
                             features::StepNominal,
                             features::AngleNominal,
                             features::PcdNominal,
                             features::EllipseNominal,
                             features::SurfaceNominal,
                             features::EdgeNominal>;
  std::string feature;  ///< "bore", "face", ... (CheckFeatureName)
  Shape shape;
};

/// What a kind of feature is, whatever its nominal: how its size error moves an offset.
struct FeatureTraits {
  std::string size_name;  ///< the LinuxCNC parameter: #<_mlp_<size_name>>
  std::string unit = "mm";
  /// Offset change per unit of size error; nullopt: the feature moves no offset (an angle, a
  /// bolt circle, a surface profile), and an update asked for is refused as input.
  std::optional<double> change_per_error;
  /// The offset it moves: a length (a face's height, a step) or else a radius (a size across).
  bool moves_length = false;
  /// It has a position a work offset can be set from (a centre, a face's point).
  bool has_position = false;
};

/// A measure request's feature part, every field read and checked.
struct FeatureRequest {
  FeatureNominal nominal;
  FeatureTraits traits;
  /// The size decided on where there is a choice: "ls" or "functional" (a bore, a boss),
  /// "x" or "y" (a rectangle), "major" or "minor" (an ellipse); empty where there is none.
  std::string size;
  features::SizeSpec spec;                       ///< that size's nominal and band
  std::optional<features::SizeSpec> other_spec;  ///< a rectangle's other size, held to its band
  std::optional<double> position_tol_mm;         ///< true position (ISO 1101), where asked
  std::optional<double> flatness_tol_mm;         ///< a face's flatness, where asked
  std::optional<double> cylindricity_tol_mm;     ///< a bore's or boss's cylindricity, where asked
};

struct Measured {
  std::string feature;
  FeatureTraits traits;
  double size = 0.0;
  features::SizeSpec spec;
  nlohmann::json fields;
  features::FitEvidence fe;
  /// Other tolerances of the job that were exceeded (flatness, true position, the second size
  /// of a rectangle): each makes the verdict out of tolerance.
  std::vector<std::string> problems;
  std::optional<features::BoreMeasurement> bore;  ///< for the picture: a roundness plot
  std::vector<features::DeviationPanel> panels;   ///< for the picture of the others
  /// Where the feature was found and where its nominal put it (a centre, a face's point): a
  /// work offset update moves by the difference. Unset for features without a position.
  std::optional<geometry::Vec3> found_mcs;
  geometry::Vec3 nominal_mcs = geometry::Vec3::Zero();
};

/// request.feature and request.nominal. Throws JobInputError (an unknown feature, listing the
/// known ones; a field missing or wrong). `data_dir` resolves relative nominal files.
FeatureNominal ParseFeatureNominal(const nlohmann::json& request, const std::string& data_dir);

/// The nominal, and the size, tolerances and limits a measure request gives it. Throws
/// JobInputError.
FeatureRequest ParseFeatureRequest(const nlohmann::json& request, const std::string& data_dir);

/// Throws features::FeatureError (not measurable from these points).
Measured MeasureFeature(const FeatureRequest& request, const Evidence& evidence);

/// The views a feature's capture plan needs (mlp::features plan.h).
std::vector<features::ViewTarget> FeatureViews(const FeatureNominal& nominal,
                                               const features::PlanOptions& options);

}  // namespace mlp::service
