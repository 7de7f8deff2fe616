#pragma once
/// @file Pictures a person reads at the machine (SVG: any browser or the controller's file
/// viewer shows it, and it stays sharp when zoomed): the fitted feature, its deviations
/// colour-mapped and magnified, the nominal and its tolerance, the numbers and the verdict.

#include "mlp/features/feature.h"

#include <string>
#include <vector>

namespace mlp::features {

struct BoreReport {
  std::string title;  ///< e.g. "job 42 - bore - vmc-1"
  bool boss = false;  ///< the functional size is then the smallest ring over it
  double nominal_mm = 0, upper_tol_mm = 0, lower_tol_mm = 0;
  BoreMeasurement bore;
  double size_mm = 0, error_mm = 0;
  std::string verdict;   ///< "in tolerance", "out of tolerance", ...
  std::string decision;  ///< what was (not) written and why
  std::string time_utc;
};

/// A roundness plot: the least-squares circle, the mean radial deviation per degree magnified
/// (blue inside, red outside the fitted circle), the nominal and its tolerance band at the same
/// magnification, and the numbers.
std::string BoreReportSvg(const BoreReport& report);

/// A surface seen square on, each point coloured by its deviation (from its fitted plane, or
/// from the nominal for a surface patch).
struct DeviationPanel {
  std::string title;
  std::vector<geometry::Vec2> xy_mm;  ///< in the surface's plane
  std::vector<double> deviation_mm;
};

/// The panel of a measured face: its points (`points_mcs` as given to MeasurePlane) on the
/// fitted plane, coloured by their distance from it.
DeviationPanel FacePanel(const std::string& title,
                         const geometry::Points3& points_mcs,
                         const PlaneMeasurement& face);

/// Points seen along `normal` (a surface patch against its nominal), coloured by `deviation_mm`.
DeviationPanel PointsPanel(const std::string& title,
                           const geometry::Points3& points_mcs,
                           const std::vector<double>& deviation_mm,
                           const geometry::Vec3& normal);

/// The panel of a hole: its wall's mean radial deviation per degree around the fitted centre.
DeviationPanel RingPanel(const std::string& title, const BoreMeasurement& hole);

struct FeatureReport {
  std::string title, verdict, decision, time_utc;
  std::vector<std::string> lines;      ///< the numbers, one per line
  std::vector<DeviationPanel> panels;  ///< up to 4 drawn
};

/// Any feature: up to four deviation panels (a colour scale shared by all, to the 99th
/// percentile of the deviations so that a chip does not wash the rest out), the numbers and
/// the verdict.
std::string FeatureReportSvg(const FeatureReport& report);

}  // namespace mlp::features
