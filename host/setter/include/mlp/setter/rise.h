#pragma once
/// @file The rise p before blocking (seed 003: "the rise p may also be used to predict the
/// threshold crossing"). Just before a pin's edge starts to block the beam, light bent round it
/// reaches the receiver: a bump above the clear level. Its peak lies a fixed distance before
/// the threshold crossing along the approach (the calibration curve's `rise_mm`), so once the
/// bump has passed, the crossing's moment is known ahead at the feed.
///
/// The peak's moment: a least-squares parabola through the bump's upper part (the smoothed
/// share above 1 + `half_share`), from running sums (a DSP's fixed memory), its vertex. A
/// bump shorter than `min_s` is noise. The same estimator reads the calibration pin's bump and
/// a measurement's, so the diffraction's ripple on the bump biases both alike.

namespace mlp::setter {

/// A bump shorter than this is noise (the rise lasts about a tenth of a second at 6 mm/min).
constexpr double kRiseMinS = 0.0005;

class RiseFinder {
 public:
  RiseFinder(double half_share, double min_s);
  /// One smoothed share (of the clear level) at t [s]; true when this sample ends the first
  /// bump long enough (its peak is then PeakTimeS()).
  bool Add(double t_s, double share);
  bool Found() const { return found_; }
  double PeakTimeS() const { return peak_t_; }

 private:
  double level_, min_s_;
  bool in_ = false, found_ = false;
  double t0_ = 0, peak_t_ = 0;
  double s_[5] = {0, 0, 0, 0, 0};  // sums of tau^k
  double sy_[3] = {0, 0, 0};       // sums of tau^k y
  double last_t_ = 0;
};

}  // namespace mlp::setter
