#pragma once
/// @file The features a measure job knows: each is measured from the mapped points (the
/// feature mathematics, mlp::features) into what the shared decision needs: the toleranced
/// size, its readings for the reply and the evidence for the plausibility gate. The request's
/// text is read by the service (its JSON face); here everything is typed.

#include "mlp/features/composite.h"
#include "mlp/features/decision.h"
#include "mlp/features/edge.h"
#include "mlp/features/feature.h"
#include "mlp/features/plan.h"
#include "mlp/features/report.h"
#include "mlp/features/surface.h"
#include "mlp/jobs/evidence.h"
#include "mlp/jobs/readings.h"

#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace mlp::jobs {

/// A feature's nominal: what a plan places its views by and a measurement segments the points
/// by.
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
  std::string feature;  ///< "bore", "face", ... (FeatureNames)
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

/// The features known, by name ("bore", "boss", "face", ...).
std::vector<std::string> FeatureNames();
/// A known feature's traits; nullopt for any other name.
std::optional<FeatureTraits> TraitsOf(const std::string& feature);

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
  Readings readings;
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

/// Throws features::FeatureError (not measurable from these points).
Measured MeasureFeature(const FeatureRequest& request, const Evidence& evidence);

/// The views a feature's capture plan needs (mlp::features plan.h).
std::vector<features::ViewTarget> FeatureViews(const FeatureNominal& nominal,
                                               const features::PlanOptions& options);

}  // namespace mlp::jobs
