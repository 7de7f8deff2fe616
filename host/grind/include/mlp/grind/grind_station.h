#pragma once
/// @file A grinding cell on a machine (seed 001 on a controller): the camera over the work,
/// the work's silhouette as the wheel takes it away, the top-of-stroke trigger and, at each
/// frame taken, the profile error at the NC's current cutting point with its compensation.
/// `mlp-grind-hal` puts it into LinuxCNC's HAL: the slide's x, y, z and the NC's theoretical
/// C in; the capture, the measurement and the compensation out, which the running program
/// applies as a work offset (samples/linuxcnc/mlprobe-sim/subs/mlp_grind_point.ngc). On a real
/// machine the frame is the camera's and only the trigger and the measurement are kept; here
/// the virtual work knows the truth the tests check.
///
/// Frames (machine coordinates in mm are the camera's: it is fixed to the bed, calibrated to
/// the machine's x, y): the slide's x, y is where the NC put the wheel's nose centre; the real
/// centre is that plus the machine's error. While the wheel's height is below the work's top it
/// sweeps its section (wheel.h) out of the work. The "before" frame of a cutting point is the
/// last frame taken before the wheel first cut at its C; every later frame taken at that C
/// after a cut is measured against it.

#include "mlp/grind/grind_job.h"
#include "mlp/grind/grind_measure.h"
#include "mlp/grind/stroke_trigger.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace mlp::grind {

struct GrindStationConfig {
  GrindJob job;                 ///< camera, nominal, wheel (radius, bevel), limit e, stock
  StrokeTriggerConfig trigger;  ///< on the wheel's height
  double work_top_mm = 0.0;     ///< the wheel cuts while its height is below this
  geometry::Vec2 machine_error_mm = geometry::Vec2::Zero();  ///< real less commanded centre
  double wear_mm = 0.0;                                      ///< the nose's lost radius
  /// A compensation longer than this is refused (the program stops; nothing is applied).
  double max_compensation_mm = 0.1;
  void Validate() const;  ///< throws GrindInputError naming the field
};

struct StationMeasurement {
  StrokeTop top;
  geometry::Vec2 c_mm = geometry::Vec2::Zero(), mi_mm = geometry::Vec2::Zero();
  PointResult point;
  bool refused = false;  ///< not measurable, or the compensation over the limit
  std::string why;       ///< when refused, or why a measured point's compensation was withheld
};

class GrindStation {
 public:
  GrindStation(const GrindStationConfig& config, unsigned seed);
  /// One sample of the machine at `time_s`: the slide's x, y (the commanded nose centre,
  /// machine coordinates) and the wheel's height, and the NC's theoretical C. A measurement
  /// when this sample's top was captured after a cut at C; nothing otherwise.
  std::optional<StationMeasurement> Step(double time_s,
                                         const geometry::Vec2& slide_mm,
                                         double height_mm,
                                         const geometry::Vec2& nc_c_mm);
  /// The virtual machine's error from now on (a test's or an operator's "what if").
  void SetMachineError(const geometry::Vec2& error_mm);
  int Tops() const { return trigger_.Tops(); }
  int Captures() const { return captures_; }
  int Cuts() const { return static_cast<int>(strokes_.size()); }
  /// A measurement was made since the wheel last cut (its result stands for the work now).
  bool Fresh() const { return fresh_; }
  /// The last frame taken (the stock before any) and the strokes' truth.
  const std::vector<std::uint8_t>& LastFrame() const { return last_frame_; }

 private:
  void Cut(const geometry::Vec2& slide_mm, const geometry::Vec2& nc_c_mm);
  StationMeasurement Measure(const StrokeTop& top, const geometry::Vec2& nc_c_mm) const;

  GrindStationConfig cfg_;
  geometry::Profile2 nominal_;
  StrokeTrigger trigger_;
  unsigned seed_;
  std::vector<WheelStroke> strokes_;
  std::vector<std::uint8_t> last_frame_, before_;
  std::optional<geometry::Vec2> cut_c_;  // the C the wheel last cut at
  bool cut_since_capture_ = false, fresh_ = false;
  int captures_ = 0;
};

}  // namespace mlp::grind
