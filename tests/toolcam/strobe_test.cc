// Strobe planning against seed 000's worked examples (every number in them reproduced, the
// seed's two arithmetic slips named), and the plan's own promises checked by simulating every
// pulse: inside its frame's window, at its position's angle, every position covered once.

#include "mlp/toolcam/strobe.h"

#include <cmath>
#include <set>

#include <gtest/gtest.h>

namespace mlp::toolcam {
namespace {

constexpr double kSeedRoundingUs = 0.05;  // the seed prints microseconds to 0.1 or 1
constexpr double kSeedRoundingS = 0.005;  // and seconds to 0.01
constexpr double kSeedWholeUs = 1.0;      // or whole microseconds
constexpr double kExactUs = 1e-6;         // a plan's own arithmetic, in microseconds
constexpr double kExact = 1e-9;           // and in seconds, rpm, Hz

// Simulates the plan: each pulse inside its frame's window (clear of the blanking), its centre
// at the angle of its position (counted from image 0's angle, to the plan's stated error), and
// every position shown exactly once.
void ExpectPlanKeepsItsPromises(const StrobeRequest& r, const StrobePlan& p) {
  ASSERT_EQ(p.position.size(), static_cast<size_t>(p.positions));
  EXPECT_EQ(std::set<int>(p.position.begin(), p.position.end()).size(),
            static_cast<size_t>(p.positions));
  if (!r.synchronised) return;
  ASSERT_EQ(p.first_pulse_us.size(), p.position.size());
  const double frame_us = 1e6 / r.frame_rate_hz, rev_us = 60e6 / p.rpm;
  double angle0 = 0;
  for (size_t i = 0; i < p.position.size(); ++i) {
    for (int k = 0; k < p.pulses_per_image; ++k) {
      const double start = p.first_pulse_us[i] + k * p.pulse_spacing_us;
      EXPECT_GE(start, r.blanking_us - 1e-9) << "image " << i;
      EXPECT_LE(start + p.pulse_width_us, frame_us - r.blanking_us + 1e-9) << "image " << i;
      const double centre_rev =
          (static_cast<double>(i) * frame_us + start + p.pulse_width_us / 2) / rev_us;
      if (i == 0 && k == 0) angle0 = centre_rev;
      // Degrees from where this image's position says, wrapped to +-180.
      double off =
          std::fmod((centre_rev - angle0) * 360.0 - p.position[i] * r.resolution_deg, 360.0);
      off -= 360.0 * std::round(off / 360.0);
      EXPECT_LE(std::abs(off), 2 * p.worst_angle_error_deg + 1e-9) << "image " << i;
    }
  }
}

StrobeRequest Request(double rpm, double fps, double resolution_deg) {
  StrobeRequest r;
  r.rpm = rpm, r.frame_rate_hz = fps, r.resolution_deg = resolution_deg;
  return r;
}

TEST(Strobe, Example1_27000RpmHundredImagesNeedPulsesUnder22us) {
  // 27000 rpm = 450 rev/s, 100 images (3.6 deg): a step passes in 22.2 us.
  const StrobePlan p = PlanStrobe(Request(27000, 50, 3.6));
  EXPECT_EQ(p.positions, 100);
  EXPECT_NEAR(p.step_time_us, 22.2, kSeedRoundingUs);
  EXPECT_LE(p.pulse_width_us, p.step_time_us);
  EXPECT_GT(p.pulse_width_us, p.step_time_us - 0.1);  // the 0.1 us timer's grid
  ExpectPlanKeepsItsPromises(Request(27000, 50, 3.6), p);
}

// Example 1 as the seed sets it up: the camera free-running at 60 images/s, its timer and the
// strobe's not synchronised, 100 images in "1.66 s" at a pulse rate of "450 (100/101) = 445.5
// pulses/s". That train steps 3.6 deg a pulse (each pulse 1.01 turns after the last), but it
// cannot give one position an image: a frame lasts 7.4 of its pulses, so a whole frame's
// exposure shows 7 or 8 positions at once; and a short exposure catching one pulse a frame
// lands 7 or 8 positions on each time, which in 100 frames (1.66 s) shows only 65 of the 100
// positions. The plan: one pulse a frame at the frame rate and a speed (26964 rpm, 0.13 %
// slower) at which each image advances 49 of 100 positions (coprime): 100 positions in 1.67 s.
TEST(Strobe, Example1_FreeRunningAt60FramesAndTheSeedsPulseTrainNamed) {
  const double seed_rate_hz = 450.0 * 100 / 101, frame_s = 1.0 / 60;
  EXPECT_NEAR(seed_rate_hz, 445.5, 0.05);
  EXPECT_NEAR(450.0 / seed_rate_hz - 1, 0.01, kExact);  // 3.6 deg a pulse
  std::set<int> pulses_in_a_frame, caught;
  for (int k = 0; k < 100; ++k) {
    const auto first = static_cast<long>(std::ceil(k * frame_s * seed_rate_hz - 1e-9));
    const auto next = static_cast<long>(std::ceil((k + 1) * frame_s * seed_rate_hz - 1e-9));
    pulses_in_a_frame.insert(static_cast<int>(next - first));
    caught.insert(static_cast<int>(first % 100));  // the one pulse a short exposure catches
  }
  EXPECT_EQ(pulses_in_a_frame, (std::set<int>{7, 8}));  // 7 or 8 positions in one image
  EXPECT_EQ(caught.size(), 65u);                        // or 65 of the 100 positions
  StrobeRequest r = Request(27000, 60, 3.6);
  r.synchronised = false;
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.pulses_per_image, 1);
  EXPECT_NEAR(p.pulse_rate_hz, 60.0, kExact);
  EXPECT_NEAR(p.duration_s, 1.66, kSeedRoundingS + 0.002);  // 100 / 60 = 1.667: the seed cuts
  EXPECT_TRUE(p.rpm_changed);
  EXPECT_NEAR(p.rpm, 26964, 0.5);
  EXPECT_EQ(p.skip, 49);
  EXPECT_NEAR(p.step_time_us, 22.2, kSeedRoundingUs + 0.01);
  ExpectPlanKeepsItsPromises(r, p);
}

TEST(Strobe, Example2_7200RpmAt45FramesTwoPulsesARevolutionApart) {
  // 7200 rpm = 120 rev/s, camera free at 45 images/s with the strobe locked to it (0.1 us
  // timer): two pulses per image 1/120 s apart, 100 images in 2.22 s, pulses under 83 us.
  const StrobeRequest r = Request(7200, 45, 3.6);
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.pulses_per_image, 2);
  EXPECT_NEAR(p.pulse_spacing_us, 1e6 / 120, kExactUs);
  EXPECT_NEAR(p.duration_s, 2.22, kSeedRoundingS);
  EXPECT_NEAR(p.step_time_us, 83.3, kSeedRoundingUs);  // the seed: 0.000083 s
  EXPECT_FALSE(p.rpm_changed);
  ExpectPlanKeepsItsPromises(r, p);
}

TEST(Strobe, Example3_5000RpmAt50FramesOnePulsePerImage) {
  // 5000 rpm = 83.33 rev/s, 50 images/s synchronised to a 1.6 us strobe timer, 1.8 deg: 200
  // images in 4 s, one pulse each. The pulse bound is (1/83.33) (1.8/360) = 60.0 us; the seed
  // prints 56 us because it divides by 88.33 instead of its own 83.33 rev/s.
  StrobeRequest r = Request(5000, 50, 1.8);
  r.timer_resolution_us = 1.6;
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.positions, 200);
  EXPECT_NEAR(p.duration_s, 4.0, kExact);
  EXPECT_EQ(p.pulses_per_image, 1);
  EXPECT_NEAR(p.step_time_us, 60.0, kSeedRoundingUs);
  EXPECT_NEAR((1e6 / 88.33) * (1.8 / 360), 56.6, kSeedRoundingUs);  // the seed's figure
  EXPECT_NEAR(p.pulse_width_us, 59.2, kExact);                      // 37 steps of the 1.6 us timer
  // One pulse an image at 50 images/s is 50 pulses/s; the seed's "close to 83.33 pulses/s" is
  // the tool's revolutions per second.
  EXPECT_NEAR(p.pulse_rate_hz, 50.0, kExact);
  ExpectPlanKeepsItsPromises(r, p);
}

TEST(Strobe, Example4_3610RpmAt60FramesStepsOneDegreePerImage) {
  // 3610 rpm = 60.1667 rev/s against 60 images/s: each image 1/360 turn further, 360 images
  // in 6 s, pulses under (1/60) (1/360) s = 46 us.
  const StrobeRequest r = Request(3610, 60, 1.0);
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.skip, 1);
  EXPECT_FALSE(p.rpm_changed);
  EXPECT_NEAR(p.duration_s, 6.0, kExact);
  EXPECT_NEAR(p.step_time_us, 46.2, kSeedRoundingUs);  // the seed: 0.000046 s
  ExpectPlanKeepsItsPromises(r, p);
}

TEST(Strobe, Example5_70RpmElectrodeStepsByAPrime) {
  // An EDM electrode at 70 rpm, 60 images/s: each image 7/360 turn further; 7 is prime and
  // 360 / 7 is not whole, so 360 images cover every degree, in 6 s. A degree passes in
  // 2381 us at 70 rpm (the seed's 46 us repeats example 4's figure).
  const StrobeRequest r = Request(70, 60, 1.0);
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.skip, 7);
  EXPECT_FALSE(p.rpm_changed);
  EXPECT_NEAR(p.duration_s, 6.0, kExact);
  EXPECT_NEAR(p.step_time_us, 1e6 / (70.0 / 60) / 360, kExactUs);
  EXPECT_NEAR(p.step_time_us, 2381, kSeedWholeUs);
  // Two more slips: the seed's "60 rpm equals 1.1667 rev/s" is 70 rpm's rate (60 rpm is 1), and
  // the prime it asks for is the fraction's numerator (7 of 7/360), not its denominator.
  EXPECT_NEAR(p.rpm / 60, 1.1667, 5e-5);
  EXPECT_NE(p.rpm, 60.0);
  EXPECT_NE(360 % p.skip, 0);
  ExpectPlanKeepsItsPromises(r, p);
}

TEST(Strobe, ProposesTheNearestSpeedThatCoversEveryPosition) {
  // 72 rpm at 60 images/s advances 7.2 degrees per image: 70 rpm steps by 7 and covers all.
  StrobeRequest r = Request(72, 60, 1.0);
  r.rpm_tolerance = 0.05;
  const StrobePlan p = PlanStrobe(r);
  EXPECT_TRUE(p.rpm_changed);
  EXPECT_NEAR(p.rpm, 70.0, kExact);
  EXPECT_EQ(p.skip, 7);
  EXPECT_NE(p.note.find("run the spindle at 70.00 rpm"), std::string::npos) << p.note;
  ExpectPlanKeepsItsPromises(r, p);
  r.rpm_tolerance = 0.02;  // 2.8 % away: refused, naming the speed that would work
  try {
    PlanStrobe(r);
    ADD_FAILURE() << "planned beyond the allowed speed change";
  } catch (const StrobeError& e) {
    EXPECT_NE(std::string(e.what()).find("needs 70.00 rpm"), std::string::npos) << e.what();
  }
}

TEST(Strobe, FreeRunningFiresOncePerFrame) {
  StrobeRequest r = Request(3610, 60, 1.0);
  r.synchronised = false;
  const StrobePlan p = PlanStrobe(r);
  EXPECT_EQ(p.pulses_per_image, 1);
  EXPECT_NEAR(p.pulse_rate_hz, 60.0, kExact);
  EXPECT_TRUE(p.first_pulse_us.empty());
  EXPECT_NE(p.note.find("free-running"), std::string::npos);
  ExpectPlanKeepsItsPromises(r, p);
  // 7200 rpm free-running at 45 images/s advances 2.6667 revolutions an image: 66.67 of 100
  // positions, which would repeat every 3 images. 67 steps cover all 100: at 7209 rpm.
  r = Request(7200, 45, 3.6);
  r.synchronised = false;
  const StrobePlan q = PlanStrobe(r);
  EXPECT_EQ(q.skip, 67);
  EXPECT_NEAR(q.rpm, (2 + 0.67) * 45 * 60, kExact);
  ExpectPlanKeepsItsPromises(r, q);
}

TEST(Strobe, RefusesWhatCannotBeDoneAndSaysWhy) {
  const auto why = [](const StrobeRequest& r) {
    try {
      PlanStrobe(r);
    } catch (const StrobeError& e) {
      return std::string(e.what());
    }
    return std::string("planned");
  };
  StrobeRequest fast = Request(60000, 500, 0.25);  // a 0.25 deg step passes in 0.69 us
  fast.blanking_us = 100;
  EXPECT_NE(why(fast).find("shorter than the illuminator"), std::string::npos) << why(fast);
  EXPECT_NE(why(Request(1000, 25, 0.1)).find("over the limit of 60.0 s"), std::string::npos);
  EXPECT_NE(why(Request(1000, 50, 0.7)).find("not a whole number"), std::string::npos);
  EXPECT_NE(why(Request(0, 50, 1)).find("rpm must be"), std::string::npos);
  EXPECT_NE(why(Request(1000, std::nan(""), 1)).find("frame rate"), std::string::npos);
  StrobeRequest r = Request(1000, 1000, 1);  // a 1 ms frame with 0.5 ms blanking each end
  EXPECT_NE(why(r).find("no room for a pulse"), std::string::npos) << why(r);
}

}  // namespace
}  // namespace mlp::toolcam
