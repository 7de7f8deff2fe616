#include "mlp/setter/setter_station.h"

#include <algorithm>
#include <cmath>

namespace mlp::setter {

void SetterStationConfig::Validate() const {
  beam.Validate();
  if (tool.Teeth() < 1 || tool.Teeth() > BeamProcessor::kMaxTeeth || !(tool.LongestRadius() > 0))
    throw SetterInputError("setter station: the tool needs 1..16 teeth with radii > 0");
  if (!(approach_sign == 1.0 || approach_sign == -1.0))
    throw SetterInputError("setter station: approach_sign must be +1 or -1");
  if (!std::isfinite(beam_mm) || !std::isfinite(base_reach_mm))
    throw SetterInputError("setter station: beam_mm and base_reach_mm must be finite");
  if (processor.sample_rate_hz != beam.sample_rate_hz)
    throw SetterInputError("setter station: the processor samples at the beam's rate");
}

BeamSource::BeamSource(const SetterStationConfig& config, unsigned seed)
    : cfg_(config), rng_(seed), noise_(0.0, std::max(config.beam.noise_v, 1e-300)) {
  cfg_.Validate();
  if (cfg_.beam.drops_per_s > 0)
    next_drop_t_ = std::exponential_distribution<double>(cfg_.beam.drops_per_s)(rng_);
}

double BeamSource::MaxIntrusion(double spindle_mm) const {
  return cfg_.approach_sign * (spindle_mm - cfg_.beam_mm) + cfg_.base_reach_mm +
         cfg_.tool.LongestRadius();
}

float BeamSource::Sample(double t, double spindle_mm, double rpm) {
  ToolInBeam tool = cfg_.tool;
  tool.rpm = rpm;
  const double e =
      cfg_.approach_sign * (spindle_mm - cfg_.beam_mm) + cfg_.base_reach_mm + tool.Reach(t);
  const double pass = Transmission(cfg_.beam, e, tool.width_mm);
  double v = cfg_.beam.clear_v * (cfg_.beam.reflective ? 1.0 - pass : pass);
  // Coolant drops as in GenerateSignal, drawn as time comes: one at a time, Poisson gaps.
  if (cfg_.beam.drops_per_s > 0 && t >= next_drop_t_) {
    std::uniform_real_distribution<double> unit(0, 1);
    const double half = 0.00015 + 0.0008 * unit(rng_);
    const double depth = 0.2 + 0.7 * unit(rng_);
    drop_ = {next_drop_t_ + 4 * half, half, depth};
    next_drop_t_ =
        drop_.t + 4 * half + std::exponential_distribution<double>(cfg_.beam.drops_per_s)(rng_);
  }
  if (drop_.t >= 0 && std::abs(t - drop_.t) < 4 * drop_.half)
    v *= 1 - drop_.depth * std::exp(-std::pow((t - drop_.t) / drop_.half, 2));
  if (cfg_.beam.noise_v > 0) v += noise_(rng_);
  return static_cast<float>(v);
}

SetterStation::SetterStation(const SetterStationConfig& config, unsigned seed)
    : cfg_(config), source_(config, seed) {}

void SetterStation::Arm(double rpm) {
  ProcessorConfig pc = cfg_.processor;
  pc.rpm = rpm;
  processor_.emplace(pc);  // validates
  armed_ = true, rpm_ = rpm, t_ = 0, samples_ = 0, deepest_share_ = 1, have_position_ = false;
  truth_edge_mm_ = std::numeric_limits<double>::quiet_NaN();
}

void SetterStation::Disarm() { armed_ = false; }

bool SetterStation::Advance(double dt_s, double spindle_mm) {
  if (!armed_) return false;
  if (!have_position_) last_mm_ = spindle_mm, have_position_ = true;
  const double rate = cfg_.beam.sample_rate_hz;
  const double t_end = t_ + std::max(dt_s, 0.0);
  const long due = std::lround(t_end * rate);
  const double from_mm = last_mm_, t_from = t_;
  const double prev_edge = source_.MaxIntrusion(from_mm);
  for (; samples_ < due; ++samples_) {
    const double t = static_cast<double>(samples_) / rate;
    const double f = t_end > t_from ? std::clamp((t - t_from) / (t_end - t_from), 0.0, 1.0) : 1.0;
    const double mm = from_mm + f * (spindle_mm - from_mm);
    const float volts = source_.Sample(t, mm, rpm_);
    deepest_share_ = std::min(deepest_share_, volts / cfg_.processor.curve.clear_v);
    processor_->Push(volts);
  }
  // Truth: the spindle where the longest tooth's reach crosses the beam's centre.
  const double now_edge = source_.MaxIntrusion(spindle_mm);
  if (std::isnan(truth_edge_mm_) && (prev_edge < 0) != (now_edge < 0) && now_edge != prev_edge)
    truth_edge_mm_ = from_mm + (spindle_mm - from_mm) * (0 - prev_edge) / (now_edge - prev_edge);
  t_ = t_end, last_mm_ = spindle_mm;
  return processor_->Triggered();
}

}  // namespace mlp::setter
