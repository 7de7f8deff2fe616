// The image trigger at the top of the wheel's stroke and the grinding cell on a machine
// (seed 001), without a controller: the slide's samples as a servo loop would give them, the
// virtual work ground by a wheel with a known error, the compensation applied as a work
// offset between points as the sample macro does (the same cell in the real LinuxCNC:
// tests/host/linuxcnc_grind_test.cc).

#include "mlp/grind/grind_station.h"

#include "mlp/base/args.h"
#include "mlp/host/grind_station_args.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

namespace mlp::grind {
namespace {

using geometry::Vec2;
constexpr double kSampleS = 0.001;     // the servo loop's sampling
constexpr double kTopTimeTolS = 0.02;  // the top's moment (2 um of sensor noise at a crank's top)
constexpr double kFrameBelowTopMm = 0.02;  // the frame's moment: hysteresis + noise below the top

// A crank's stroke: the height from -3 to `top` mm at `hz`, sampled with the sensor's noise.
TEST(StrokeTrigger, OneFrameAtEachTopClearOfTheView) {
  StrokeTriggerConfig cfg;
  cfg.clear_mm = 2.0;
  StrokeTrigger trigger(cfg);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.002);
  constexpr double kHz = 2.0;
  int captured = 0, low = 0;
  double worst_time = 0, worst_drop = 0;
  for (double t = 0; t < 5.0; t += kSampleS) {
    const double top = t < 3.0 ? 5.0 : 1.5;  // the last four strokes turn in the camera's view
    const double z = (top - 3) / 2 - (top + 3) / 2 * std::cos(2 * M_PI * kHz * t);
    const auto got = trigger.Add(t, z + noise(rng));
    if (!got) continue;
    const double true_top_s = (std::floor(t * kHz - 0.5) + 0.5) / kHz;
    worst_time = std::max(worst_time, std::abs(got->top_time_s - true_top_s));
    worst_drop = std::max(worst_drop, got->top_mm - got->height_mm);
    EXPECT_NEAR(got->top_time_s, true_top_s, kTopTimeTolS) << "t " << t;
    EXPECT_LT(got->top_mm - got->height_mm, kFrameBelowTopMm);
    EXPECT_EQ(got->capture, top > cfg.clear_mm) << "t " << t;
    (got->capture ? captured : low) += 1;
  }
  EXPECT_EQ(captured, 6);  // tops at 0.25, 0.75 ... 2.75 s
  EXPECT_EQ(low, 4);       // 3.25 ... 4.75 s: declared, no frame
  std::printf("stroke trigger: 10 tops, top's moment within %.1f ms, frame %.1f um below it\n",
              worst_time * 1e3, worst_drop * 1e3);
  // Held at the top with the sensor's noise (an NC's pause), a sample lost: nothing.
  StrokeTrigger still(cfg);
  for (double t = 0; t < 1.0; t += kSampleS) EXPECT_FALSE(still.Add(t, 5.0 + noise(rng)));
  EXPECT_FALSE(still.Add(1.0, std::nan("")));
  EXPECT_EQ(still.Tops(), 0);
  cfg.hysteresis_mm = cfg.min_stroke_mm;
  EXPECT_THROW(StrokeTrigger{cfg}, GrindInputError);
}

// The machine: moves the slide, strokes and reads the station as a servo loop would.
class Machine {
 public:
  explicit Machine(GrindStation* s) : station_(s) {}
  Vec2 offset_mm = Vec2::Zero();  // the work offset the program adds its compensations to
  std::vector<StationMeasurement> results;
  // One cutting point as subs/mlp_grind_point.ngc grinds it: to C at the top, two strokes
  // from 5 down to -3 mm at 10 mm/s, a turn 1 mm down at the top; then its compensation.
  void Point(const Vec2& c) {
    for (int k = 0; k < 2; ++k) Move(c, 5.0, -3.0), Move(c, -3.0, 5.0);
    Move(c, 5.0, 4.0), Move(c, 4.0, 5.0);
    ASSERT_TRUE(station_->Fresh());
    const StationMeasurement& m = results.back();
    if (!m.refused && m.point.feed != Feed::kGood) offset_mm += m.point.compensation_mm;
  }

 private:
  void Move(const Vec2& c, double from, double to) {
    const int n = static_cast<int>(std::abs(to - from) / (10.0 * kSampleS));
    for (int i = 1; i <= n; ++i) {
      t_ += kSampleS;
      const auto m = station_->Step(t_, c + offset_mm, from + (to - from) * i / n, c);
      if (m) results.push_back(*m);
    }
  }
  GrindStation* station_;
  double t_ = 0;
};

GrindStationConfig Cell(const Vec2& error_mm) {
  GrindStationConfig cfg;
  cfg.job.profile = DemoProfile();
  cfg.trigger.clear_mm = 2.0;
  cfg.machine_error_mm = error_mm;
  return cfg;
}

// The wheel 30 um off at 80 deg: the first point's frames show the under-feed and where the
// wheel really was; its compensation moves the work offset, and the points after it are
// ground on the nominal (good). Every top a frame.
TEST(GrindStation, TheFirstPointsCompensationPutsTheNextOnTheNominal) {
  const Vec2 error = 0.03 * Vec2(std::cos(80 * M_PI / 180), std::sin(80 * M_PI / 180));
  GrindStation station(Cell(error), 5);
  Machine machine(&station);
  const geometry::Profile2 p(DemoProfile());
  for (const double s : {1.0, 1.6, 2.2}) machine.Point(p.At(s).point + p.At(s).normal);
  // Each point: a top before its first stroke (not the first point's: the wheel started at
  // the top), one between its strokes, one at the turn; measured at each after a cut.
  EXPECT_EQ(station.Tops(), 8);
  EXPECT_EQ(station.Captures(), 8);
  ASSERT_EQ(machine.results.size(), 6u);
  const StationMeasurement& first = machine.results[1];
  ASSERT_FALSE(first.refused) << first.why;
  EXPECT_EQ(first.point.feed, Feed::kUnderFeed);
  constexpr double kErrorTolMm = 0.001, kDirTolDeg = 2.0;
  EXPECT_NEAR(first.point.error_mm, error.norm(), kErrorTolMm);
  EXPECT_LT(std::acos(first.point.error_dir.dot(error.normalized())) * 180 / M_PI, kDirTolDeg);
  for (size_t k = 2; k < machine.results.size(); ++k)
    EXPECT_EQ(machine.results[k].point.feed, Feed::kGood) << "measurement " << k;
  EXPECT_LT((machine.offset_mm + error).norm(), kErrorTolMm);
  std::printf("grind station: error found %.2f um (true %.2f); offset after %.2f um from -error\n",
              first.point.error_mm * 1e3, error.norm() * 1e3,
              (machine.offset_mm + error).norm() * 1e3);
}

// The wheel 120 um off: the compensation would be over the 0.1 mm limit: refused, nothing to
// apply (the macro stops).
TEST(GrindStation, ACompensationOverTheLimitIsRefused) {
  const Vec2 error = 0.12 * Vec2(std::cos(80 * M_PI / 180), std::sin(80 * M_PI / 180));
  GrindStation station(Cell(error), 6);
  Machine machine(&station);
  const geometry::Profile2 p(DemoProfile());
  machine.Point(p.At(1.0).point + p.At(1.0).normal);
  ASSERT_FALSE(machine.results.empty());
  EXPECT_TRUE(machine.results.back().refused);
  EXPECT_NE(machine.results.back().why.find("over the limit"), std::string::npos)
      << machine.results.back().why;
  EXPECT_EQ(machine.offset_mm, Vec2::Zero());
  GrindStationConfig bad = Cell(Vec2::Zero());
  bad.trigger.clear_mm = -1.0;  // the camera would see the wheel in the work
  EXPECT_THROW(GrindStation(bad, 1), GrindInputError);
}

// mlp-grind-hal's arguments, parsed without LinuxCNC.
TEST(GrindStationArgs, ReadTheCellAndRefuseWhatIsWrong) {
  const host::GrindStationArgs a = host::ParseGrindStationArgs(
      {"--name", "grind-2", "--sim-error-mm", "0.01,-0.02", "--max-comp-mm", "0.05", "--sampler",
       "3", "--servo-period-ns", "500000"});
  EXPECT_EQ(a.name, "grind-2");
  EXPECT_EQ(a.sampler_channel, 3);
  EXPECT_EQ(a.servo_period_ns, 500000);
  EXPECT_EQ(host::ParseGrindStationArgs({}).sampler_channel, 0);
  EXPECT_EQ(a.config.machine_error_mm, Vec2(0.01, -0.02));
  EXPECT_EQ(a.config.max_compensation_mm, 0.05);
  EXPECT_EQ(a.config.trigger.clear_mm, 2.0);
  EXPECT_FALSE(a.config.job.profile.empty());  // the demo's profile without --job
  EXPECT_THROW(host::ParseGrindStationArgs({"--name", "Grind!"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--sim-error-mm", "0.01"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--sim-error-mm", "0.01,x"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--clear-mm", "-1"}), GrindInputError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--sampler", "8"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--sampler", "-1"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--servo-period-ns", "0"}), base::UsageError);
  EXPECT_THROW(host::ParseGrindStationArgs({"--job", "/nonexistent/job.json"}), base::UsageError);
}

}  // namespace
}  // namespace mlp::grind
