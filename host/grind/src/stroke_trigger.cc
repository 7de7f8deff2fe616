#include "mlp/grind/stroke_trigger.h"

#include "mlp/grind/grind_frame.h"

#include <algorithm>
#include <cmath>

namespace mlp::grind {

void StrokeTriggerConfig::Validate() const {
  if (!(min_stroke_mm > 0) || !std::isfinite(min_stroke_mm))
    throw GrindInputError("stroke trigger: min_stroke_mm must be > 0");
  if (!(hysteresis_mm > 0) || !(hysteresis_mm < min_stroke_mm))
    throw GrindInputError("stroke trigger: hysteresis_mm must be > 0 and under min_stroke_mm");
  if (!std::isfinite(clear_mm)) throw GrindInputError("stroke trigger: clear_mm must be finite");
}

StrokeTrigger::StrokeTrigger(const StrokeTriggerConfig& config) : config_(config) {
  config_.Validate();
}

std::optional<StrokeTop> StrokeTrigger::Add(double t, double z) {
  if (!std::isfinite(t) || !std::isfinite(z)) return std::nullopt;
  if (!started_) {
    started_ = true, low_mm_ = z;
    return std::nullopt;
  }
  if (!rising_) {  // below: wait for a stroke's worth of rise from the lowest point
    low_mm_ = std::min(low_mm_, z);
    if (z - low_mm_ >= config_.min_stroke_mm) rising_ = true, high_mm_ = z, high_time_s_ = t;
    return std::nullopt;
  }
  if (z > high_mm_) {
    high_mm_ = z, high_time_s_ = t;
    return std::nullopt;
  }
  if (high_mm_ - z < config_.hysteresis_mm) return std::nullopt;
  rising_ = false, low_mm_ = z, ++tops_;
  return StrokeTop{high_time_s_, high_mm_, t, z, z >= config_.clear_mm};
}

}  // namespace mlp::grind
