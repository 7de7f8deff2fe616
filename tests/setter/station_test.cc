// The setter on a machine (setter_station.h): the virtual beam rendered in step with an axis
// that the test moves as a control would (irregular cycles, as a user-space HAL component
// sees them), the processor's skip, and the edge it implies against the virtual tool's truth.
// A length along Z with a tool not turning; a radius along X with a two-tooth tool turning
// through coolant drops. The same as mlp-setter-hal runs in LinuxCNC (tests/host/
// linuxcnc_setter_test.cc), without the controller's latency.

#include "mlp/base/args.h"
#include "mlp/host/setter_station_args.h"
#include "mlp/setter/setter_station.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

namespace mlp::setter {
namespace {

constexpr double kEdgeTolMm = 0.001;  // the edge (length, radius) against the truth, as beam_test
constexpr double kFeedMmS = 0.1;      // 6 mm/min
constexpr double kExactMm = 1e-9;     // the truth's own interpolation

CalibrationCurve PinCurve() {
  ToolInBeam pin;
  pin.tooth_radius_mm = {3.0};
  Motion m;
  m.gap_mm = 0.15, m.duration_s = 2.5;
  const BeamSignal s = GenerateSignal(BeamModel(), pin, m, 1);
  return CalibrateFromPin(s.volts, s.sample_rate_hz, 6.0, true);
}

SetterStationConfig Station(double beam_mm, std::vector<double> teeth_mm, double base_mm) {
  SetterStationConfig c;
  c.processor.curve = PinCurve();
  c.processor.teeth = static_cast<int>(teeth_mm.size());
  c.tool.tooth_radius_mm = std::move(teeth_mm);
  c.beam_mm = beam_mm, c.base_reach_mm = base_mm, c.approach_sign = -1.0;
  return c;
}

struct Outcome {
  bool triggered = false;
  double latched_mm = 0, edge_mm = 0, truth_mm = 0;
};

// The axis from `start_mm` along -1 at the feed, in cycles of 100-500 us (seeded), until the
// skip or `travel_mm`; the position "latched" is the cycle's end, as motion would latch it.
Outcome Approach(
    SetterStation* station, double start_mm, double travel_mm, double rpm, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> cycle_s(100e-6, 500e-6);
  station->Arm(rpm);
  double mm = start_mm;
  Outcome r;
  while (start_mm - mm < travel_mm) {
    const double dt = cycle_s(rng);
    mm -= kFeedMmS * dt;
    if (station->Advance(dt, mm)) {
      r.triggered = true, r.latched_mm = mm;
      r.edge_mm = mm + station->trigger().edge_offset_mm;  // moving -: it went past by that
      break;
    }
  }
  // A trigger at the predicted crossing may come a hair before the tooth gets there: the axis
  // runs on (as it does while motion stops) until the truth is seen, at most 5 um.
  for (double on = 0; r.triggered && std::isnan(station->TruthEdgeMm()) && on < 0.005;) {
    const double dt = cycle_s(rng);
    mm -= kFeedMmS * dt, on += kFeedMmS * dt;
    station->Advance(dt, mm);
  }
  r.truth_mm = station->TruthEdgeMm();
  return r;
}

TEST(SetterStation, ALengthAlongZWithATipNotTurning) {
  const double beam_z = -100.0, length = 87.654, tip_radius = 0.5;
  SetterStation station(Station(beam_z, {tip_radius}, length - tip_radius), 3);
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const Outcome r = Approach(&station, beam_z + length + 0.08, 0.2, 0.0, seed);
    ASSERT_TRUE(r.triggered) << seed;
    EXPECT_NEAR(r.truth_mm, beam_z + length, kExactMm);
    std::printf("length: edge error %+.3f um (skip %.2f um past it)\n",
                (r.edge_mm - beam_z - length) * 1e3, (r.edge_mm - r.latched_mm) * 1e3);
    EXPECT_NEAR(r.edge_mm - beam_z, length, kEdgeTolMm) << seed;
  }
}

TEST(SetterStation, ARadiusAlongXWithATwoToothToolTurningThroughDrops) {
  const double beam_x = 50.0;
  SetterStationConfig c = Station(beam_x, {3.0, 3.01}, 0.0);
  c.beam.drops_per_s = 10;
  for (unsigned seed = 1; seed <= 5; ++seed) {
    SetterStation station(c, seed);
    const Outcome r = Approach(&station, beam_x + 3.01 + 0.06, 0.12, 1500.0, seed);
    ASSERT_TRUE(r.triggered) << seed;
    EXPECT_NEAR(r.truth_mm, beam_x + 3.01, kExactMm);
    std::printf("radius: edge error %+.3f um, tooth %d\n", (r.edge_mm - beam_x - 3.01) * 1e3,
                station.trigger().tooth);
    EXPECT_NEAR(r.edge_mm - beam_x, 3.01, kEdgeTolMm) << seed;
  }
}

// Stopped short of the beam (a broken tool's search ends above where its tip should be): no
// skip, and the light it saw says how close it came.
TEST(SetterStation, NoSkipWhenTheToolNeverReachesTheBeam) {
  const double beam_z = -100.0, length = 80.0;
  SetterStation station(Station(beam_z, {0.5}, length - 0.5), 4);
  const Outcome r = Approach(&station, beam_z + length + 0.3, 0.2, 0.0, 1);  // stops 0.1 mm above
  EXPECT_FALSE(r.triggered);
  EXPECT_GT(station.DeepestShare(), 0.95);
  EXPECT_TRUE(std::isnan(r.truth_mm));
}

TEST(SetterStation, BadConfigurationsAreInputErrors) {
  SetterStationConfig c = Station(0.0, {3.0}, 0.0);
  c.approach_sign = 0.0;
  EXPECT_THROW(SetterStation(c, 1), SetterInputError);
  c = Station(0.0, {3.0}, 0.0);
  c.processor.sample_rate_hz = 50000;  // not the beam's
  EXPECT_THROW(SetterStation(c, 1), SetterInputError);
  SetterStation station(Station(0.0, {3.0}, 0.0), 1);
  EXPECT_THROW(station.Arm(-5.0), SetterInputError);
}

TEST(SetterStationArgs, OptionsAreCheckedAndNamed) {
  EXPECT_THROW(host::ParseSetterStationArgs({"--beam-mm", "1"}), base::UsageError);  // no curve
  EXPECT_THROW(host::ParseRadiiList("--teeth-mm", "3,x"), base::UsageError);
  EXPECT_THROW(host::ParseRadiiList("--teeth-mm", ""), base::UsageError);
  EXPECT_EQ(host::ParseRadiiList("--teeth-mm", "3,3.01").size(), 2u);
}

}  // namespace
}  // namespace mlp::setter
