#pragma once
/// @file A tool setter on a machine: the beam processor fed, sample by sample, with the signal
/// of a virtual beam that runs in step with the machine's axis (seed 003: "output: a skip
/// signal to the CNC"). `mlp-setter-hal` puts it into LinuxCNC's HAL: the axis position in,
/// the skip (motion.probe-input) out. On a real setter the source is the receiver's ADC and
/// only the processor is kept; here the virtual beam knows the truth the tests check.
///
/// Geometry: the approach runs along one machine axis, towards decreasing (`approach_sign`
/// -1) or increasing (+1) coordinates. The tool reaches `base_reach_mm` + its teeth's reach
/// (ToolInBeam::Reach) past the spindle's position along the approach: a length setting (Z-,
/// a tool not turning) has base = length - tip radius, so the tip is `length` below the gauge
/// line; a radius setting (X-, turning) has base = 0, each tooth reaching its radius. With the
/// beam's centre at `beam_mm` on that axis, the intrusion (how far the tool reaches past the
/// centre along the approach) is approach_sign * (spindle - beam) + base + Reach(t).

#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"

#include <limits>
#include <optional>
#include <random>

namespace mlp::setter {

struct SetterStationConfig {
  BeamModel beam;               ///< the virtual beam (its sample rate is the processor's)
  ToolInBeam tool;              ///< the virtual tool's teeth; rpm comes with Arm
  double approach_sign = -1.0;  ///< the approach's direction along the axis
  double beam_mm = 0.0;         ///< the beam's centre on the axis (machine coordinates)
  double base_reach_mm = 0.0;   ///< the tool's reach beyond its teeth (a length's gauge line)
  ProcessorConfig processor;    ///< curve, teeth, feed, threshold; rpm comes with Arm
  void Validate() const;        ///< throws SetterInputError naming the field
};

/// The virtual beam's voltage for a stream of axis positions: the beam model's transmission
/// of the tool's reach, noise and coolant drops (Poisson, drawn as they come).
class BeamSource {
 public:
  BeamSource(const SetterStationConfig& config, unsigned seed);
  /// The sample at time t [s] with the spindle at `spindle_mm` on the approach's axis.
  float Sample(double t_s, double spindle_mm, double rpm);
  /// Intrusion of the longest tooth's reach, were it pointing along the approach [mm].
  double MaxIntrusion(double spindle_mm) const;

 private:
  struct Drop {
    double t = -1, half = 0, depth = 0;
  };
  SetterStationConfig cfg_;
  std::mt19937 rng_;
  std::normal_distribution<double> noise_;
  Drop drop_;
  double next_drop_t_ = 0;
};

class SetterStation {
 public:
  SetterStation(const SetterStationConfig& config, unsigned seed);
  /// Starts a measurement: a fresh processor for a tool turning at `rpm` (0: not turning).
  /// Throws SetterInputError when that processor's configuration is out of range.
  void Arm(double rpm);
  void Disarm();
  bool Armed() const { return armed_; }
  /// `dt_s` of time passed, in which the spindle moved linearly from its last position to
  /// `spindle_mm`: their samples rendered and processed. True once triggered.
  bool Advance(double dt_s, double spindle_mm);
  bool Triggered() const { return processor_ && processor_->Triggered(); }
  /// The processor's trigger (valid once Triggered()).
  const Trigger& trigger() const { return processor_->trigger(); }
  const BeamProcessor* processor() const { return processor_ ? &*processor_ : nullptr; }
  /// The deepest share of the clear light seen since armed (1: nothing in the beam).
  double DeepestShare() const { return deepest_share_; }
  long Samples() const { return samples_; }
  /// Truth: where the spindle was when the longest tooth's reach met the beam's centre,
  /// interpolated from the positions given (NaN before).
  double TruthEdgeMm() const { return truth_edge_mm_; }

 private:
  SetterStationConfig cfg_;
  BeamSource source_;
  std::optional<BeamProcessor> processor_;
  bool armed_ = false;
  double rpm_ = 0, last_mm_ = 0, t_ = 0, deepest_share_ = 1;
  double truth_edge_mm_ = std::numeric_limits<double>::quiet_NaN();
  long samples_ = 0;
  bool have_position_ = false;
};

}  // namespace mlp::setter
