#pragma once
// What the tool camera's tests share: a strobe plan's frames of a tool rendered by the virtual
// camera (its truth known) and measured against a nominal, and which edge faced a side in a
// frame.

#include "mlp/base/units.h"
#include "mlp/toolcam/measure.h"

#include <cmath>
#include <random>
#include <vector>

namespace mlp::toolcam::test {

struct MeasuredRun {
  ToolMeasurement m;
  std::vector<double> turn;  ///< each frame's true turn [rad]
  double start_turn = 0;     ///< the turn at angular position 0 [rad]
  /// Where edge e faces +y at height h, as the measurement counts angles (position x step).
  double PeakDeg(const ToolDescription& t, int e, double h) const {
    const double d = (M_PI / 2 - t.EdgeAngle(e, h, 0.0) - start_turn) * 180 / M_PI;
    return d - 360.0 * std::floor(d / 360.0);
  }
};

struct RunSetup {
  double resolution_deg = 7.2;  ///< 50 images at 5000 rpm, 50 images/s
  MeasureOptions options;
  /// The camera the measurement is given (its calibration), when not the one that rendered.
  const ToolCameraModel* measured_with = nullptr;
};

// A strobe plan's frames of a tool (5000 rpm, pulses a tenth of a step), starting at a seeded
// random turn.
struct RenderedSeries {
  std::vector<std::vector<std::uint8_t>> frames;
  std::vector<int> positions;
  int position_count = 0;
  std::vector<double> turn;  ///< each frame's true turn [rad]
  double start_turn = 0;
};

// The turn a series drawn with `seed` starts at (RenderSeries' first draw) [deg]: what a chuck
// that defines the tool's angle would say.
inline double StartTurnDeg(unsigned seed) {
  std::mt19937 rng(seed);
  return std::uniform_real_distribution<double>(0, 2 * M_PI)(rng) * 180 / M_PI;
}

inline RenderedSeries RenderSeries(const ToolDescription& tool,
                                   const ToolCameraModel& c,
                                   unsigned seed,
                                   double resolution_deg = 7.2) {
  StrobeRequest r;
  r.rpm = 5000, r.frame_rate_hz = 50, r.resolution_deg = resolution_deg;
  r.pulse_share = 0.1;
  const StrobePlan plan = PlanStrobe(r);
  std::mt19937 rng(seed);
  RenderedSeries s;
  s.start_turn = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
  const double blur = plan.pulse_width_us * 1e-6 * plan.rpm / 60 * 2 * M_PI;
  s.positions = plan.position, s.position_count = plan.positions;
  for (int pos : plan.position) {
    s.turn.push_back(s.start_turn + 2 * M_PI * pos / plan.positions);
    s.frames.push_back(RenderToolFrame(tool, c, s.turn.back(), blur, rng).pixels);
  }
  return s;
}

// Renders a plan's frames of `tool` and measures them against the nominal.
inline MeasuredRun RenderAndMeasure(const ToolDescription& tool,
                                    const ToolDescription& nominal,
                                    const ToolCameraModel& c,
                                    unsigned seed,
                                    const RunSetup& setup = {}) {
  const RenderedSeries s = RenderSeries(tool, c, seed, setup.resolution_deg);
  MeasuredRun run;
  run.start_turn = s.start_turn, run.turn = s.turn;
  run.m = MeasureTool(s.frames, s.positions, s.position_count, nominal,
                      setup.measured_with ? *setup.measured_with : c, setup.options);
  return run;
}

// The large tools' camera (measure_test's): 400 x 600 px at 4 um, the edge at `radius_mm` in
// the middle, the axis out of view.
inline ToolCameraModel FlankCamera(double radius_mm) {
  ToolCameraModel c;
  c.width_px = 400, c.height_px = 600;
  c.axis_u_px = 200 - radius_mm / c.mm_per_px;
  c.tip_v_px = 520;
  c.drops_per_frame = 0;
  return c;
}

// 640 x 560 px at 4 um: 2.56 x 2.24 mm, the spindle axis in the middle, the tip 60 px above
// the bottom (h up to 2.0 mm): a tool up to D2.3 wholly in view.
inline ToolCameraModel WholeToolCamera() {
  ToolCameraModel c;
  c.width_px = 640, c.height_px = 560;
  c.axis_u_px = 319.5, c.tip_v_px = 500;
  c.drops_per_frame = 0;
  return c;
}

using base::WrapDeg;  // the project's one (mlp/base/units.h)

// The edge nearest the `side` (+1: +y, -1: -y) at height h in the frame turned `turn`.
inline int EdgeFacing(const ToolDescription& t, double turn, double h, int side = 1) {
  int best = 0;
  double best_y = -1e300;
  for (int k = 0; k < t.flutes; ++k) {
    const double y = side * std::sin(t.EdgeAngle(k, h, turn));
    if (y > best_y) best_y = y, best = k;
  }
  return best;
}

}  // namespace mlp::toolcam::test
