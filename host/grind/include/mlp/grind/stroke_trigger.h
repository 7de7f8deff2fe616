#pragma once
/// @file The image trigger at the top of the wheel's stroke (seed 001).
///
/// While it cuts, the wheel reciprocates along its axis (z, up away from the work); a position
/// sensor on the slide gives its height, and at the top of each stroke the camera takes the
/// frame: there the wheel's speed is zero, it touches nothing (no sparks) and it is out of the
/// camera's depth of field, so the work's silhouette is sharp. The detector follows the
/// sensor's samples: a stroke is a rise of at least `min_stroke_mm` from the last bottom; its
/// top is declared once the height falls `hysteresis_mm` below the stroke's highest sample (a
/// sensor's noise, or an NC's pause at the top, does not trigger twice), and a frame is taken
/// only when the wheel is then above `clear_mm` (a reversal lower down would show the wheel).

#include <optional>

namespace mlp::grind {

struct StrokeTriggerConfig {
  double min_stroke_mm = 0.5;
  double hysteresis_mm = 0.01;
  double clear_mm = 0.0;  ///< the wheel above this height is out of the camera's view
  void Validate() const;  ///< throws GrindInputError naming the field
};

struct StrokeTop {
  double top_time_s = 0.0, top_mm = 0.0;  ///< the stroke's highest sample
  double time_s = 0.0, height_mm = 0.0;   ///< where it was declared (the frame's moment)
  bool capture = false;                   ///< the wheel clear of the view: take the frame
};

class StrokeTrigger {
 public:
  explicit StrokeTrigger(const StrokeTriggerConfig& config);
  /// One sample of the sensor; the stroke's top when this sample declares one. Samples that
  /// are not finite are ignored (a sensor's dropout changes nothing).
  std::optional<StrokeTop> Add(double time_s, double height_mm);
  int Tops() const { return tops_; }

 private:
  StrokeTriggerConfig config_;
  bool started_ = false, rising_ = false;
  double low_mm_ = 0.0, high_mm_ = 0.0, high_time_s_ = 0.0;
  int tops_ = 0;
};

}  // namespace mlp::grind
