#pragma once
/// @file Strobe planning for shadow images of a tool turning in the spindle (seed 000): a fixed
/// back-lit camera sees the tool's silhouette frozen by short light pulses. Given the speed,
/// the camera's frame rate and the angular resolution wanted, the plan says how long a pulse
/// may be (the time the tool takes to turn one angular step), how many pulses each image
/// collects (one revolution apart, so they all freeze the same angle), when in each frame they
/// fire (never near the frame change: blanking), and in which order the images visit the
/// angular positions so that every one is covered (a step coprime with the number of
/// positions: the seed's prime skip).
///
/// Timing model: frame i starts at i / frame_rate; the tool turns rpm / 60 revolutions per
/// second. Positions are counted in steps from the first image's angle (the tool's absolute
/// angle is unknown: angular indexing finds the flutes later). With synchronised timers the strobe
/// can fire at any time of a frame (to its timer's resolution); free-running, it fires once per
/// frame at the frame rate and the angle advances by what the speed gives.

#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::toolcam {

/// A request the planner cannot meet: the message says which limit and what would work.
class StrobeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct StrobeRequest {
  double rpm = 0.0;
  double frame_rate_hz = 0.0;
  double resolution_deg = 0.0;  ///< angular step; 360 must be a whole number of steps
  /// Strobe and camera timers locked together (the strobe fires at chosen times in each frame);
  /// false: both free-running, one pulse per frame at the frame rate.
  bool synchronised = true;
  double timer_resolution_us = 0.1;  ///< the strobe timer's step
  double min_pulse_us = 1.0;         ///< the shortest pulse the illuminator makes
  double blanking_us = 500.0;        ///< no pulse this close to a frame change
  double max_duration_s = 60.0;      ///< every position covered within this
  /// A slow tool (less than a revolution per frame) or a free-running pair steps through the
  /// positions by what the speed gives; the plan may then propose a speed this close (relative)
  /// to the one asked for, at which the step is a whole number of positions coprime with them.
  double rpm_tolerance = 0.02;
  int max_pulses_per_image = 8;
  /// The pulse as a share of its bound (1: the whole step, as the seed; shorter pulses blur
  /// less and need more light).
  double pulse_share = 1.0;
};

struct StrobePlan {
  int positions = 0;  ///< 360 / resolution
  double rpm = 0.0;   ///< to run at: as asked, or the proposed speed
  bool rpm_changed = false;
  double step_time_us = 0.0;    ///< the tool turns one step in this: the pulse's bound
  double pulse_width_us = 0.0;  ///< the bound rounded down to the timer (not below min)
  int pulses_per_image = 1;
  double pulse_spacing_us = 0.0;  ///< between pulses of one image: one revolution
  double pulse_rate_hz = 0.0;     ///< pulses per second
  int skip = 1;                   ///< positions advanced from one image to the next
  double duration_s = 0.0;        ///< positions / frame rate: every position once
  /// Per image: the angular position it shows (0..positions-1) and, synchronised, its first
  /// pulse's time from the frame's start [us] on the timer's grid.
  std::vector<int> position;
  std::vector<double> first_pulse_us;
  /// The most the timer's rounding moves an image's angle [deg] (half a timer step of turning;
  /// the plan centres each pulse on its position, so the blur is symmetric about it).
  double worst_angle_error_deg = 0.0;
  std::string note;  ///< what the operator should know (a proposed speed, free-running flicker)
};

/// Throws StrobeError when the request cannot be met (a pulse shorter than the illuminator
/// makes, coverage longer than allowed, no speed within the tolerance that covers every
/// position, a frame too short for a pulse beside its blanking).
StrobePlan PlanStrobe(const StrobeRequest& request);

}  // namespace mlp::toolcam
