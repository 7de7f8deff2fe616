#pragma once
/// @file A laser beam-break tool setter's receiver signal (seed 003), synthetic with its truth:
/// the voltage sampled (45-96 kHz) while a calibration pin or a turning tool with teeth of
/// possibly unequal heights moves into or out of the beam at a feed.
///
/// The beam is Gaussian (radius `beam_radius_mm` at 1/e^2) and an edge at intrusion e (its
/// reach past the beam's centre along the approach, mm) passes the share
/// T(e) = erfc(sqrt(2) e / w) / 2 of it: 1 far outside, 1/2 at the centre. Diffraction adds the
/// small rise before blocking (the receiver gathers light bent round the edge; a bell of
/// `rise` of the clear level 1.5 radii before the centre) and a ripple that grows as the edge
/// nears the beam. A turning tool reaches furthest with the tooth pointing along the approach:
/// reach = axis + max_k r_k cos(turn + 2 pi k / teeth), at least its core; one dip per tooth.
/// Coolant drops crossing the beam dim it briefly at random times.
///
/// Positions along the approach are relative to the beam's centre: the axis at time t is at
/// a(t) = -gap - r_max + dir * feed * t (dir +1 entering, -1 leaving), so the longest tooth
/// meets the centre (50 %) when the axis is at -r_max.

#include "mlp/base/input_error.h"

#include <stdexcept>
#include <vector>

namespace mlp::setter {

/// A measurement that gave no result: the pin never blocked the beam, a curve that does not
/// fall. Bad input (a file, a model, tool, motion or processor configuration out of range) is a
/// SetterInputError.
class SetterError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class SetterInputError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct BeamModel {
  double sample_rate_hz = 80000.0;
  double beam_radius_mm = 0.030;  ///< 1/e^2
  double clear_v = 4.0;           ///< the receiver's voltage with the beam clear
  double noise_v = 0.008;         ///< Gaussian, per sample
  double rise = 0.015;            ///< the rise before blocking, share of clear_v
  double ripple = 0.006;          ///< the diffraction ripple's amplitude near the beam
  double drops_per_s = 0.0;       ///< coolant drops crossing the beam (Poisson)
  /// A reflective setter: the receiver sees the light the tool reflects back, clear_v times
  /// the share the tool takes out of the beam (dark with nothing in it; a peak per tooth, the
  /// min-max-min of seed 003).
  bool reflective = false;
  void Validate() const;  ///< throws SetterInputError naming the field
};

/// What moves into the beam: a pin (not turning, `tooth_radius_mm` its one radius) or a tool
/// turning at `rpm` with its teeth equally spaced, each reaching its own radius.
struct ToolInBeam {
  double rpm = 0.0;                     ///< 0: not turning
  std::vector<double> tooth_radius_mm;  ///< one per tooth (a pin: its radius)
  double core_share = 0.6;              ///< the core between the teeth, share of the smallest
  double start_turn_rad = 0.0;          ///< tooth 0's angle from the approach at t = 0
  /// > 0: a tool thinner than the beam, this wide along the approach behind its reach (a
  /// micro drill's shank): it takes out at most erf(width / (sqrt 2 w)) of the light, under
  /// half when width < 0.95 w. 0: a solid edge.
  double width_mm = 0.0;
  int Teeth() const { return static_cast<int>(tooth_radius_mm.size()); }
  double LongestRadius() const;
  /// How far the tool reaches past its axis along the approach at time t.
  double Reach(double t_s) const;
};

struct Motion {
  double feed_mm_min = 6.0;
  double gap_mm = 0.1;   ///< entering: the longest tooth this far before the centre at t = 0
  bool entering = true;  ///< false: leaving; the longest tooth `gap_mm` past the centre at t=0
  double duration_s = 2.0;
  double Dir() const { return entering ? 1.0 : -1.0; }
  double FeedMmPerS() const { return feed_mm_min / 60.0; }
};

struct BeamSignal {
  double sample_rate_hz = 0.0;
  std::vector<float> volts;
  /// From a real setter's file (`mlprobe-beam-signal/2`); empty or 0 when it has none.
  double amplifier_hz = 0.0;    ///< the receiver amplifier's -3 dB bandwidth (first order)
  std::vector<double> axis_mm;  ///< the axis position at each sample (the approach's axis)
  std::vector<char> latch;      ///< the skip/latch channel at each sample (0/1)
  std::vector<char> index;      ///< the spindle's index pulse at each sample (0/1)
  int saturated = 0;            ///< samples at the ADC's full scale
  /// Truth: the axis position at sample i, and where it is when the longest tooth's reach
  /// meets the beam's centre (the edge position the skip signal should give).
  double axis_start_mm = 0.0, axis_feed_mm_per_sample = 0.0, axis_at_edge_mm = 0.0;
  std::vector<double> drop_times_s;
  double AxisAt(double sample) const { return axis_start_mm + axis_feed_mm_per_sample * sample; }
};

/// The share of the beam an edge at intrusion e passes, with the diffraction's rise and
/// ripple (share of the clear level); with `width_mm` > 0 a strip that wide behind the edge.
double Transmission(const BeamModel& beam, double intrusion_mm, double width_mm = 0.0);

/// Throws SetterInputError when the model, tool or motion is out of range.
BeamSignal GenerateSignal(const BeamModel& beam,
                          const ToolInBeam& tool,
                          const Motion& motion,
                          unsigned seed);

}  // namespace mlp::setter
