// The tool setter's beam signal (seed 003) against the generator's truth: the calibration
// curve from a pin, the trigger's edge position over seeded runs (the seed's 1500 rpm, 6
// mm/min: 4 um a turn), the long tooth of a two-tooth tool, no trigger from drops alone,
// leaving the beam, a pin not turning, the diameter from the dips' widths, bad settings.

#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "beam_cases.h"
#include <gtest/gtest.h>

namespace mlp::setter {
namespace {

constexpr double kFeedPerRevMm = 0.004;       // 6 mm/min at 1500 rpm: what repeatability must beat
constexpr double kEdgeTolMm = 0.001;          // each run's edge against the truth
constexpr double kLagTolMm = 0.001;           // the short tooth's lag against its true 10 um
constexpr double kRadiusTolMm = 0.015;        // the tooth's radius from the widths (0.5 %)
constexpr double kClosedForm = 1e-12;         // a closed-form value computed again
constexpr double kTailShare = 1e-9;           // the beam's Gaussian tail 0.2 mm from its centre
constexpr double kClearTolV = 0.01;           // the pin's clear level against the 4 V simulated
constexpr double kShareTol = 0.01;            // the curve's share of clear at the beam's centre
constexpr double kInverseTol = 1e-9;          // IntrusionAt and Share are each other's inverse
constexpr double kTableShareTol = 0.003;      // the table against the generator's transmission
constexpr double kRadiusFromCurveMm = 0.001;  // the beam's radius from its 10-90 % width

using test::Approach;
using test::Config;
using test::Outcome;
using test::PinCurve;
using test::Process;

TEST(BeamSignal, FollowsTheKnifeEdgeAndTheTeeth) {
  BeamModel b;
  b.rise = b.ripple = 0;
  EXPECT_NEAR(Transmission(b, 0.0), 0.5, kClosedForm);
  EXPECT_NEAR(Transmission(b, -0.2), 1.0, kTailShare);
  EXPECT_NEAR(Transmission(b, 0.2), 0.0, kTailShare);
  EXPECT_GT(Transmission(BeamModel(), -0.045), 1.005);  // the rise before blocking
  ToolInBeam tool;
  tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01};
  EXPECT_NEAR(tool.Reach(0.0), 3.0, kClosedForm);         // tooth 0 along the approach
  EXPECT_NEAR(tool.Reach(0.02), 3.01, kClosedForm);       // half a turn later: the long tooth
  EXPECT_NEAR(tool.Reach(0.01), 3.0 * 0.6, kClosedForm);  // a quarter turn: the core between them
  ToolInBeam none;
  EXPECT_THROW(GenerateSignal(BeamModel(), none, Approach(0.1, 1), 1), SetterInputError);
}

// The curve (mlprobe-beam-curve/2) is a table over the whole fall: from the clear level after
// the rise to 2 % of the light, following the generator's own transmission bin by bin.
TEST(BeamCalibration, ThePinGivesATableOverTheWholeFall) {
  const CalibrationCurve c = PinCurve();
  std::printf("curve: clear %.4f V, x %.4f..%.4f mm, w %.2f um, x(50 %%) %+.3f um +- %.4f\n",
              c.clear_v, c.lo_mm, c.hi_mm, c.beam_radius_mm * 1e3, c.IntrusionAt(0.5) * 1e3,
              c.half_light_u_mm * 1e3);
  EXPECT_NEAR(c.clear_v, 4.0, kClearTolV);
  EXPECT_NEAR(c.Share(0.0), 0.5, kShareTol);
  EXPECT_GT(c.lo_mm, c.rise_mm);              // after the rise's peak,
  EXPECT_NEAR(c.ShareHi(), 1.0, kShareTol);   // from the clear level
  EXPECT_NEAR(c.ShareLo(), 0.02, kShareTol);  // to 2 % of the light
  EXPECT_NEAR(c.beam_radius_mm, BeamModel().beam_radius_mm, kRadiusFromCurveMm);
  BeamModel model;
  for (double x = c.lo_mm; x <= c.hi_mm; x += 0.001)
    EXPECT_NEAR(c.Share(x), Transmission(model, x), kTableShareTol) << "x " << x;
  for (double share : {0.2, 0.5, 0.8, 0.99})
    EXPECT_NEAR(c.Share(c.IntrusionAt(share)), share, kInverseTol);
  const CalibrationCurve back = ParseCurve(CurveJson(c));
  EXPECT_EQ(back.table.size(), c.table.size());
  for (double x = c.lo_mm; x <= c.hi_mm; x += 0.0003) EXPECT_NEAR(back.Share(x), c.Share(x), 1e-12);
  std::vector<float> dark(10000, 0.0f);
  EXPECT_THROW(CalibrateFromPin(dark, 80000, 6, true), SetterError);  // no result: not bad input
  EXPECT_THROW(CalibrateFromPin(dark, 80000, 0, true), SetterInputError);  // no feed
}

// A curve file that is not one is bad input naming the file (the command's exit 2).
TEST(BeamCalibration, ABadCurveFileIsBadInputNamingTheFile) {
  try {
    ParseCurve(R"({"format": "mlprobe-beam-curve/1", "clear_v": 4, "lo_mm": 0, "hi_mm": 0.03,
                   "cubic": [1, 2, "x", 4]})",
               "/shop/setter/curve.json");
    ADD_FAILURE() << "a cubic with a string in it was read";
  } catch (const SetterInputError& e) {
    EXPECT_NE(std::string(e.what()).find("/shop/setter/curve.json: cubic"), std::string::npos)
        << e.what();
  }
}

// The seed's case: 1500 rpm, 6 mm/min, 4 um a turn; a two-tooth D6 whose second tooth reaches
// 10 um further; noise and 10 coolant drops a second; 30 runs, each its own start angle.
TEST(BeamProcessor, TheEdgeRepeatsFarBetterThanTheFeedPerTurn) {
  const CalibrationCurve curve = PinCurve();
  BeamModel beam;
  beam.drops_per_s = 10;
  double lo = 1e300, hi = -1e300, sum = 0, sum2 = 0, r_lo = 1e300, r_hi = -1e300;
  int runs = 0;
  for (unsigned seed = 1; seed <= 30; ++seed) {
    ToolInBeam tool;
    tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01}, tool.start_turn_rad = 0.37 * seed;
    const BeamSignal s = GenerateSignal(beam, tool, Approach(0.06, 1.2), 100 + seed);
    const Outcome r = Process(s, Config(curve, 1500, 2, true));
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;  // the long tooth's
    EXPECT_NEAR(r.lag_mm, 0.010, kLagTolMm) << "seed " << seed;
    EXPECT_NEAR(r.radius_mm, 3.01, kRadiusTolMm) << "seed " << seed;
    lo = std::min(lo, r.edge_error_mm), hi = std::max(hi, r.edge_error_mm);
    r_lo = std::min(r_lo, r.radius_mm), r_hi = std::max(r_hi, r.radius_mm);
    sum += r.edge_error_mm, sum2 += r.edge_error_mm * r.edge_error_mm, ++runs;
  }
  const double mean = sum / runs, sd = std::sqrt(sum2 / runs - mean * mean);
  std::printf(
      "30 runs: edge error mean %+.3f um, sd %.3f um, range %.3f um (feed a turn 4 um); long "
      "tooth's radius from the widths %.4f..%.4f mm (true 3.0100)\n",
      mean * 1e3, sd * 1e3, (hi - lo) * 1e3, r_lo, r_hi);
  EXPECT_LT(hi - lo, kFeedPerRevMm);
}

// The ends of the setters' sample rates (45 and 96 kHz): the same edge.
TEST(BeamProcessor, HoldsAcrossTheSampleRates) {
  for (const double fs : {45000.0, 96000.0}) {
    BeamModel beam;
    beam.sample_rate_hz = fs;
    ToolInBeam pin;
    pin.tooth_radius_mm = {3.0};
    const BeamSignal p = GenerateSignal(beam, pin, Approach(0.15, 2.5), 1);
    ProcessorConfig c = Config(CalibrateFromPin(p.volts, fs, 6.0, true), 1500, 2, true);
    c.sample_rate_hz = fs;
    beam.drops_per_s = 10;
    for (unsigned seed = 1; seed <= 5; ++seed) {
      ToolInBeam tool;
      tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01}, tool.start_turn_rad = seed;
      const Outcome r = Process(GenerateSignal(beam, tool, Approach(0.06, 1.2), 50 + seed), c);
      ASSERT_TRUE(r.triggered) << fs << " Hz, seed " << seed;
      EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << fs << " Hz, seed " << seed;
    }
  }
}

TEST(BeamProcessor, DropsAloneNeverTrigger) {
  const CalibrationCurve curve = PinCurve();
  BeamModel beam;
  beam.drops_per_s = 60;
  int rejected = 0;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    ToolInBeam tool;  // 1 mm off: it never reaches the beam in the 2 s
    tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01};
    const BeamSignal s = GenerateSignal(beam, tool, Approach(1.0, 2.0), 200 + seed);
    ASSERT_GT(s.drop_times_s.size(), 60u);
    const Outcome turning = Process(s, Config(curve, 1500, 2, true));
    EXPECT_FALSE(turning.triggered) << "seed " << seed;
    const Outcome still = Process(s, Config(curve, 0, 1, true));  // read as a pin's signal
    EXPECT_FALSE(still.triggered) << "seed " << seed;
    rejected += turning.rejections + still.rejections;
  }
  std::printf("drops alone: %d rejections in 5 runs, no trigger\n", rejected);
  EXPECT_GT(rejected, 100);
}

// Leaving the beam (10 drops a second): the long tooth is the last out, and comes onto the
// curve last: the short tooth's line must not fire the trigger.
TEST(BeamProcessor, LeavingTheBeamTriggersOnTheLastTooth) {
  const CalibrationCurve curve = PinCurve();
  for (unsigned seed = 1; seed <= 10; ++seed) {
    ToolInBeam tool;
    tool.rpm = 1500, tool.tooth_radius_mm = {3.01, 3.0}, tool.start_turn_rad = 1.1 * seed;
    BeamModel beam;
    beam.drops_per_s = 10;
    const BeamSignal s = GenerateSignal(beam, tool, Approach(0.06, 1.2, false), 300 + seed);
    const Outcome r = Process(s, Config(curve, 1500, 2, false));
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;
  }
}

// A pin not turning, with drops: the crossing's slope and hold tell the drops; the edge where
// the pin blocks half the light.
TEST(BeamProcessor, APinNotTurningTriggersAtItsCrossingNotAtADrop) {
  const CalibrationCurve curve = PinCurve();
  BeamModel beam;
  beam.drops_per_s = 20;
  int rejected = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    ToolInBeam pin;
    pin.tooth_radius_mm = {3.0};
    const BeamSignal s = GenerateSignal(beam, pin, Approach(0.06, 1.2), 400 + seed);
    const Outcome r = Process(s, Config(curve, 0, 1, true));
    ASSERT_TRUE(r.triggered) << "seed " << seed;
    EXPECT_NEAR(r.edge_error_mm, 0.0, kEdgeTolMm) << "seed " << seed;
    rejected += r.rejections;
  }
  std::printf("pin with drops: %d drops rejected before the crossing in 10 runs\n", rejected);
  EXPECT_GT(rejected, 0);
}

TEST(BeamProcessor, RefusesSettingsItCannotWorkWith) {
  const CalibrationCurve curve = PinCurve();
  ProcessorConfig c = Config(curve, 1500, 2, true);
  c.teeth = 0;
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
  c = Config(curve, 1500, 2, true);
  c.threshold_share = 0.02;  // below the curve's span
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
  c = Config(curve, 1500, 2, true);
  c.curve.hi_mm = c.curve.lo_mm;  // a curve with no span (without one: trigger_modes_test)
  EXPECT_THROW(BeamProcessor{c}, SetterInputError);
}

}  // namespace
}  // namespace mlp::setter
