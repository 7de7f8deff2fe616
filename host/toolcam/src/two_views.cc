#include "mlp/toolcam/two_views.h"

#include "mlp/base/units.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace mlp::toolcam {
namespace {

using geometry::Vec3;

void CheckViewAngle(double view_deg) {
  if (!std::isfinite(view_deg))
    throw ToolInputError("two views: the second view's angle is not a number");
  if (std::abs(std::sin(view_deg / base::kDegPerRad)) <
      std::sin(kMinViewAngleDeg / base::kDegPerRad))
    throw ToolInputError("two views: views " + std::to_string(view_deg) +
                         " deg apart are too near parallel to triangulate (at least " +
                         std::to_string(kMinViewAngleDeg) + " deg from 0 and 180)");
}

void CheckSamePulses(const ToolSeries& a, const ToolSeries& b) {
  if (a.position_count != b.position_count || a.positions != b.positions)
    throw ToolInputError(
        "two views: the series are not of the same pulses (their angular positions differ)");
}

// B's flute for each of A's: the one whose angle is A's plus the mount's within its tolerance,
// each of B's taken once. Returns the residuals (measured less the mount's angle) [deg].
std::vector<double> PairFlutes(const ToolMeasurement& a,
                               const ToolMeasurement& b,
                               const SecondView& mount,
                               std::vector<int>* b_flute) {
  if (a.flutes.size() != b.flutes.size())
    throw ToolError("two views: camera A shows " + std::to_string(a.flutes.size()) +
                    " flutes, camera B " + std::to_string(b.flutes.size()));
  std::vector<double> residual;
  std::vector<bool> taken(b.flutes.size(), false);
  for (const FluteMeasurement& fa : a.flutes) {
    int best = -1;
    double best_d = mount.tolerance_deg;
    for (size_t j = 0; j < b.flutes.size(); ++j) {
      const double d = base::WrapDeg(b.flutes[j].angle_deg - fa.angle_deg - mount.view_deg);
      if (std::abs(d) <= std::abs(best_d) && !taken[j]) best = static_cast<int>(j), best_d = d;
    }
    if (best < 0)
      throw ToolError("two views: a flute of camera A has none in camera B within " +
                      std::to_string(mount.tolerance_deg) +
                      " deg of the mount's angle: check the second view's angle");
    taken[static_cast<size_t>(best)] = true;
    b_flute->push_back(best);
    residual.push_back(best_d);
  }
  return residual;
}

}  // namespace

Vec3 Triangulate(double y_a, double h_a, double y_b, double h_b, double view_deg) {
  CheckViewAngle(view_deg);
  // y_a = y; y_b = -sin(v) x + cos(v) y: two equations in x and y.
  const double v = view_deg / base::kDegPerRad;
  return {(std::cos(v) * y_a - y_b) / std::sin(v), y_a, (h_a + h_b) / 2};
}

ToolIn3d MeasureToolFromTwoViews(const ToolSeries& a,
                                 const ToolSeries& b,
                                 const ToolDescription& nominal,
                                 const SecondView& mount,
                                 const MeasureOptions& options) {
  CheckViewAngle(mount.view_deg);
  if (!(mount.tolerance_deg > 0 && mount.tolerance_deg < 180.0 / std::max(nominal.flutes, 1)))
    throw ToolInputError("two views: the mount's tolerance must be in (0, half the pitch)");
  CheckSamePulses(a, b);
  ToolIn3d t;
  t.a = MeasureTool(a, nominal, options);
  t.b = MeasureTool(b, nominal, options);
  if (!t.a.both_flanks || !t.b.both_flanks)
    throw ToolError(std::string("two views: camera ") + (t.a.both_flanks ? "B" : "A") +
                    " does not show both flanks, so it cannot place the spindle axis");
  const std::vector<double> residual = PairFlutes(t.a, t.b, mount, &t.b_flute);
  double mean = 0, square = 0;
  for (double r : residual) mean += r / static_cast<double>(residual.size());
  for (double r : residual)
    square += (r - mean) * (r - mean) / static_cast<double>(residual.size());
  t.view_deg = mount.view_deg + mean, t.view_rms_deg = std::sqrt(square);
  CheckViewAngle(t.view_deg);
  t.depth_gain = 1.0 / std::abs(std::sin(t.view_deg / base::kDegPerRad));
  t.axis_offset_mm = Triangulate(t.a.axis_offset_mm, 0, t.b.axis_offset_mm, 0, t.view_deg);
  t.tip_h_mm = (t.a.tip_h_mm + t.b.tip_h_mm) / 2;
  t.tip_disagreement_mm = t.a.tip_h_mm - t.b.tip_h_mm;
  for (size_t k = 0; k < t.a.flutes.size(); ++k) {
    const FluteMeasurement& fa = t.a.flutes[k];
    const FluteMeasurement& fb = t.b.flutes[static_cast<size_t>(t.b_flute[k])];
    const double r = (fa.radius_mm + fb.radius_mm) / 2;
    // A sees the edge at its +y (90 deg round from x) `angle_deg` after position 0, B the
    // view's angle later: the two views' mean.
    const double seen_deg =
        fa.angle_deg + base::WrapDeg(fb.angle_deg - t.view_deg - fa.angle_deg) / 2;
    const double at_0 = (90.0 - seen_deg) / base::kDegPerRad;
    t.edge_mm.push_back(t.axis_offset_mm +
                        Vec3(r * std::cos(at_0), r * std::sin(at_0), options.h_ref_mm));
    t.radius_mm.push_back(r);
    t.radius_disagreement_mm.push_back(fa.radius_mm - fb.radius_mm);
  }
  return t;
}

}  // namespace mlp::toolcam
