// The setter's other triggers (seed 003; issue 21): without a calibration curve (a line through
// the minima in share), a reflective setter (a peak per tooth, min-max-min), a trigger on the
// dips' width, and a tool thinner than the beam that never blocks half the light (no trigger,
// and how close it came). Against the generator's truth, as beam_test.cc.

#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"

#include <cmath>
#include <cstdio>

#include "beam_cases.h"
#include <gtest/gtest.h>

namespace mlp::setter {
namespace {

using test::Approach;
using test::Config;
using test::Outcome;
using test::PinCurve;
using test::Process;

constexpr double kEdgeTolMm = 0.001;      // as beam_test: each run's edge against the truth
constexpr double kFeedPerTurnMm = 0.004;  // 6 mm/min at 1500 rpm
constexpr double kShareTol = 0.01;        // a dip's depth against the beam's closed form

ToolInBeam TwoTooth(double start_turn_rad) {
  ToolInBeam tool;
  tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01}, tool.start_turn_rad = start_turn_rad;
  return tool;
}

// The seed's case without a curve: each tooth's minima between 90 % and 15 % of the light on a
// line in share; the leading tooth's crossing of 50 % is the beam's centre.
TEST(NoCurve, TheSeedsCaseTriggersAtTheBeamsCentre) {
  BeamModel beam;
  beam.drops_per_s = 10;
  double lo = 1e300, hi = -1e300;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const BeamSignal s =
        GenerateSignal(beam, TwoTooth(0.37 * seed), Approach(0.06, 1.2), 100 + seed);
    const Outcome r = Process(s, Config(CalibrationCurve(), 1500, 2, true));
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;
    EXPECT_NEAR(r.lag_mm, 0.010, kEdgeTolMm) << "seed " << seed;  // in time, at the feed
    lo = std::min(lo, r.edge_error_mm), hi = std::max(hi, r.edge_error_mm);
  }
  std::printf("no curve, 20 runs: edge error %+.3f..%+.3f um\n", lo * 1e3, hi * 1e3);
}

TEST(NoCurve, APinIsHeldBeyondHalfTheLight) {
  BeamModel beam;
  beam.drops_per_s = 20;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    ToolInBeam pin;
    pin.tooth_radius_mm = {3.0};
    const BeamSignal s = GenerateSignal(beam, pin, Approach(0.06, 1.2), 400 + seed);
    const Outcome r = Process(s, Config(CalibrationCurve(), 0, 1, true));
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;
  }
}

// A reflective setter: dark until the tool reflects the beam, a peak per tooth (min-max-min);
// its curve from a pin the same way; the same edge.
TEST(Reflective, APeakPerToothTriggersTheSameEdge) {
  BeamModel beam;
  beam.reflective = true;
  ToolInBeam pin;
  pin.tooth_radius_mm = {3.0};
  const BeamSignal p = GenerateSignal(beam, pin, Approach(0.15, 2.5), 1);
  const CalibrationCurve curve = CalibrateFromPin(p.volts, p.sample_rate_hz, 6.0, true, true);
  EXPECT_NEAR(curve.clear_v, 4.0, 0.01);  // the full reflection
  EXPECT_NEAR(curve.Share(0.0), 0.5, 0.01);
  beam.drops_per_s = 10;
  double lo = 1e300, hi = -1e300;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const BeamSignal s =
        GenerateSignal(beam, TwoTooth(0.5 * seed), Approach(0.06, 1.2), 500 + seed);
    // The raw signal rises as the tool goes in: its peaks, not dips.
    EXPECT_LT(s.volts.front(), 0.1 * curve.clear_v);
    ProcessorConfig c = Config(curve, 1500, 2, true);
    c.reflective = true;
    const Outcome r = Process(s, c);
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;
    lo = std::min(lo, r.edge_error_mm), hi = std::max(hi, r.edge_error_mm);
  }
  std::printf("reflective, 10 runs with drops: edge error %+.3f..%+.3f um\n", lo * 1e3, hi * 1e3);
}

// The width trigger: set to the width of the long tooth's dip when it reaches the beam's
// centre (cos(phi) = 1 + x_w / r, x_w where the curve passes the width's share), with the
// threshold's line set deep (20 %) so the width fires first: at the first dip that wide, at
// most a turn's feed past the centre.
TEST(WidthTrigger, FiresWhereTheDipsReachTheWidthSet) {
  const CalibrationCurve curve = PinCurve();
  ProcessorConfig c = Config(curve, 1500, 2, true);
  c.threshold_share = 0.2;
  const double r = 3.01, x_w = curve.IntrusionAt(c.width_share);
  const double phi = std::acos(1.0 + x_w / r);
  c.width_trigger_s = 2 * phi / (2 * M_PI * 1500 / 60);
  BeamModel beam;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const BeamSignal s =
        GenerateSignal(beam, TwoTooth(0.7 * seed), Approach(0.06, 1.2), 600 + seed);
    BeamProcessor p(c);
    for (float v : s.volts) p.Push(v);
    ASSERT_TRUE(p.Triggered()) << "seed " << seed;
    EXPECT_EQ(p.trigger().cause, TriggerCause::kWidth) << "seed " << seed;
    const Trigger& t = p.trigger();
    const double edge = s.AxisAt(static_cast<double>(t.sample)) - t.edge_offset_mm;
    const double past = edge - s.axis_at_edge_mm;
    EXPECT_GE(past, -kEdgeTolMm) << "seed " << seed;
    EXPECT_LE(past, kFeedPerTurnMm + kEdgeTolMm) << "seed " << seed;
    std::printf("width trigger: %.2f um past the centre\n", past * 1e3);
  }
}

// A tool thinner than the beam (10 um against a 30 um beam radius) takes out at most
// erf(10 / (30 sqrt 2)) = 26 % of the light: passing right through, turning or not, it never
// reaches the 50 % threshold: no trigger (not a false one at some other point), and the deepest
// share says how close it came.
TEST(SmallTool, NeverTriggersAndSaysHowCloseItCame) {
  const CalibrationCurve curve = PinCurve();
  const double width = 0.010, w = BeamModel().beam_radius_mm;
  const double deepest = 1.0 - std::erf(width / (w * std::sqrt(2.0)));
  ToolInBeam wire;
  wire.tooth_radius_mm = {0.5}, wire.width_mm = width;
  const BeamSignal still = GenerateSignal(BeamModel(), wire, Approach(0.1, 2.5), 1);
  BeamProcessor pin(Config(curve, 0, 1, true));
  for (float v : still.volts) pin.Push(v);
  EXPECT_FALSE(pin.Triggered());
  EXPECT_NEAR(pin.DeepestShare(), deepest, kShareTol);
  ToolInBeam drill = wire;
  drill.rpm = 1500, drill.tooth_radius_mm = {0.5, 0.5};
  const BeamSignal turning = GenerateSignal(BeamModel(), drill, Approach(0.1, 2.5), 2);
  BeamProcessor p(Config(curve, 1500, 2, true));
  for (float v : turning.volts) p.Push(v);
  EXPECT_FALSE(p.Triggered());
  EXPECT_NEAR(p.DeepestShare(), deepest, kShareTol);
  std::printf("a 10 um tool: deepest share %.3f (closed form %.3f), not turning %.3f\n",
              p.DeepestShare(), deepest, pin.DeepestShare());
}

TEST(TriggerModes, SettingsTheyCannotWorkWithAreRefused) {
  ProcessorConfig c = Config(CalibrationCurve(), 1500, 2, true);
  c.reflective = true;  // the full reflection level comes from the curve
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
  c = Config(CalibrationCurve(), 1500, 2, true);
  c.threshold_share = 0.95;  // beyond the near-linear span
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
  c = Config(CalibrationCurve(), 1500, 2, true);
  c.width_trigger_s = -1;
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
}

}  // namespace
}  // namespace mlp::setter
