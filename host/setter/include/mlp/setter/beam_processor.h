#pragma once
/// @file The setter's signal processed as its DSP would (seed 003): one sample in, the state
/// updated, memory fixed whatever the signal's length (rings of a few dips per tooth).
///
/// A turning tool: the signal (a 9-sample average) is followed through its extremes with a
/// hysteresis; a max-min-max is a dip (its minimum to a sub-sample by a parabola, its width
/// between the crossings of a fixed share). A dip counts only
/// - on the teeth's schedule: at least two of the last 8 dips lie whole tooth periods before
///   it (a coolant drop comes at random; the supporting dips are confirmed with it);
/// - in its tooth's band: once a tooth has 3 extremes, a new one within `band_mm` of its line.
/// A dip's deepest point is read from the raw samples round the average's minimum (the
/// average's minimum is biased by the dip's curvature: 0.66 um on a D10 at 3000 rpm, 50 kHz):
/// each sample's share, the amplifier's lag undone when its bandwidth is known
/// (u = y + tau dy/dt), through the curve into intrusion, a least-squares parabola through those
/// near the deepest, its vertex.
/// With a curve, each tooth's minima lie on a line in time whose slope is the feed, known: each
/// minimum alone says where its tooth is (its intercept a = x - feed t). A tooth's intercept is
/// the weighted mean of its minima that agree within `band_mm` (weights: the share's noise
/// through the curve's slope, and the curve's scale uncertainty times the distance to the
/// threshold, which an extrapolation carries); the leading tooth (the largest intercept: the
/// longest entering, the last leaving) fires once it has as many minima as the feed per turn
/// lets into the curve's span (1 at 20 um a turn on a 22 um beam, up to `fit_min`), one of
/// them within `confirm_share` of the threshold or past it, and every other tooth is on the
/// curve or has passed the beam since (a tooth unseen in the span then reaches less); one minimum
/// fewer once the leader's next pass has come and gone without one (a drop spoiled it, or the tool
/// left the beam). A dip whose shoulders (a quarter of a tooth period either side) are dimmed lies
/// in a coolant drop: rejected. The trigger fires when its crossing is due, or at once if already
/// past, saying how far the axis moved since. The clear level is followed between the dips (the
/// laser's power drifts from the calibration's). The dips' widths grow as the tool goes in: with
/// the tooth's tip crossing the width's intrusion x_w at turn angles +-phi, cos(phi) = (x_w - axis)
/// / r falls linearly with the axis: its rate against the feed is the tooth's radius.
///
/// A tool not turning (a pin): the signal crossing the threshold share, its slope matching
/// the calibration curve at the feed (a drop falls far faster) and held there `hold_s` (a drop
/// passes). A drop over the crossing itself makes the fall too steep; when the light then stays
/// beyond the threshold longer than a drop lasts (`drop_max_s`), the pin crossed under the
/// drop, and the curve says when: the share now is how far it has gone past.
///
/// Without a calibration curve (seed 003's "a line through the minima"): the clear level is
/// the median of the first `clear_s`'s 1 ms means, and the beam is taken as Gaussian, its
/// radius unknown: share = erfc(z) / 2 with z linear in the intrusion, so each tooth's minima,
/// as z = erfcinv(2 share) between `line_share_lo` and `line_share_hi`, lie on a line in time
/// (a line through the shares themselves bends with the beam's edge: measured +1.0..+1.7 um
/// late). The trigger is where the leading tooth's line crosses the threshold: at 50 %, the
/// beam's centre, the edge the curve gives. A pin is then checked by its hold alone.
/// A predicted crossing fires only once the leading tooth has a minimum within
/// `confirm_share` of the threshold: a tool thinner than the beam, whose dips stop short of
/// it, is not extrapolated into a false trigger.
/// A reflective setter (its light rising as the tool enters, a min-max-min per tooth) is read
/// as the share 1 - volts / clear_v, with its curve made the same way.
/// `rise_predicts` (a pin entering, with a curve that knows its rise p): the rise's peak
/// predicts when the crossing is due (rise.h); a crossing within `rise_window_mm` of the
/// prediction (at the feed) fires at once, without the hold (a drop comes at random, the
/// rise says when the pin's edge arrives); elsewhere the hold decides as before.
/// `width_trigger_s` adds seed 003's other trigger: a confirmed dip of the leading tooth as
/// wide as that (its width grows as the tool goes in).

#include "mlp/setter/calibration_curve.h"
#include "mlp/setter/rise.h"

#include <array>
#include <limits>
#include <string>

namespace mlp::setter {

struct ProcessorConfig {
  double sample_rate_hz = 80000.0;
  double rpm = 0.0;  ///< 0: not turning
  int teeth = 1;
  double feed_mm_min = 6.0;
  bool entering = true;
  CalibrationCurve curve;
  double threshold_share = 0.5;    ///< of the clear light: the trigger's level
  double width_share = 0.8;        ///< a dip's width between its crossings of this share
  int fit_min = 4;                 ///< a tooth's extremes on its line before it can trigger
  double fit_tol_mm = 0.001;       ///< their rms about the line
  double band_mm = 0.002;          ///< a tooth's next extreme this close to its line
  double gate_share = 0.04;        ///< of a tooth period: the schedule's window
  double hysteresis_share = 0.02;  ///< smaller swings are noise
  double hold_s = 0.003;           ///< not turning: beyond the threshold this long
  double drop_max_s = 0.008;       ///< the longest a coolant drop darkens the beam
  bool reflective = false;         ///< the receiver sees the tool's reflection (needs a curve)
  double width_trigger_s = 0.0;    ///< > 0: also fire on a leading tooth's dip this wide
  double confirm_share = 0.15;     ///< a line fires once a minimum is this near the threshold
  bool rise_predicts = false;      ///< a pin: the rise p predicts the crossing (needs a curve)
  double rise_window_mm = 0.003;   ///< a crossing this near the prediction fires at once
  // Without a curve (curve.clear_v == 0):
  double clear_s = 0.02;        ///< the clear level from this much signal first
  double z_tol = 0.025;         ///< a tooth's minima's rms about their line in z (~0.5 um)
  double z_band = 0.05;         ///< a tooth's next minimum this close to its line in z (~1 um)
  double line_share_hi = 0.85;  ///< minima on a line only between these shares
  double line_share_lo = 0.1;
  /// The receiver amplifier's -3 dB bandwidth [Hz] (first order); 0: unknown, not undone.
  double amplifier_hz = 0.0;
  double scale_uncertainty = 0.01;  ///< the curve's x scale against the tool's beam (a share)
  bool HasCurve() const { return curve.clear_v > 0; }
  void Validate() const;  ///< throws SetterInputError naming the field
};

/// What fired: a tooth's line crossing the threshold, a dip as wide as width_trigger_s, a
/// pin's held crossing, or a pin's crossing where its rise predicted it.
enum class TriggerCause { kLine, kWidth, kPin, kRise };
const char* ToString(TriggerCause c);

struct Trigger {
  long sample = -1;  ///< the sample that fired it (-1: not yet)
  double time_s = 0.0;
  double threshold_time_s = 0.0;  ///< when the threshold was crossed (the line's prediction)
  /// How far the axis has moved past the edge when the trigger fired, along its motion [mm]:
  /// the edge is the position the control latches minus this.
  double edge_offset_mm = 0.0;
  int tooth = -1;    ///< the tooth whose line triggered; -1 not turning
  int extremes = 0;  ///< on its line
  TriggerCause cause = TriggerCause::kLine;
  /// A pin with rise_predicts: when the rise said the crossing was due (NaN: no rise seen).
  double predicted_time_s = std::numeric_limits<double>::quiet_NaN();
  /// A tooth's crossing predicted with the feed's slope: the edge's standard uncertainty from
  /// its minima [mm] (NaN otherwise).
  double edge_sigma_mm = std::numeric_limits<double>::quiet_NaN();
};

enum class Rejected { kOffSchedule, kOutsideBand, kTooSteep, kNotHeld, kDimmed };
const char* ToString(Rejected r);

struct Rejection {
  long sample = 0;
  Rejected reason = Rejected::kOffSchedule;
};

class BeamProcessor {
 public:
  static constexpr int kMaxTeeth = 16;
  static constexpr int kRing = 8;        ///< dips kept for the schedule, extremes per tooth
  static constexpr int kSmooth = 9;      ///< the running average's length
  static constexpr int kSlopeMax = 512;  ///< samples in the pin's slope window (1 ms)
  /// Raw samples kept for a dip's deepest point and its shoulders (3/4 of a tooth period: 2000
  /// rpm, 2 teeth at 96 kHz).
  static constexpr int kRaw = 4096;

  /// Throws SetterInputError for a configuration out of range.
  explicit BeamProcessor(const ProcessorConfig& config);
  /// One sample in; true when it fired the trigger.
  bool Push(float volts);
  bool Triggered() const { return trigger_.sample >= 0; }
  const Trigger& trigger() const { return trigger_; }
  /// The leading tooth's radius from its dips' widths [mm]; NaN before 3 widths.
  double ToothRadiusMm() const;
  /// How far tooth k's line lies behind the leading tooth's [mm] (its shorter reach); NaN
  /// while either has fewer than 2 extremes.
  double ToothLagMm(int tooth) const;
  int LeadingTooth() const;
  long Samples() const { return n_; }
  /// The deepest dip's share of the clear light so far (a pin: the lowest average); 1 before
  /// any. A tool thinner than the beam never takes it under the threshold: no trigger, and
  /// this says how close it came.
  double DeepestShare() const { return deepest_share_; }
  /// rise_predicts: when the rise says the threshold crossing is due [s]; NaN before.
  double PredictedCrossingS() const { return predicted_cross_t_; }
  /// The clear level the shares are of [V]: the curve's, or (without one) measured; NaN
  /// while it is being measured.
  double ClearV() const { return clear_v_; }
  int RejectionCount(Rejected r) const { return rejection_count_[static_cast<size_t>(r)]; }
  /// Every reason's rejections together.
  int RejectionCount() const {
    int n = 0;
    for (int c : rejection_count_) n += c;
    return n;
  }
  /// The last 16 rejections, oldest first.
  std::array<Rejection, 16> RecentRejections(int* count) const;
  /// Why no trigger came, for a person (empty once triggered): the tool never took the light
  /// under the threshold, or (turning) the feed per turn let fewer than `fit_min` of a
  /// tooth's minima fall in the curve's span (90 % to 10 % of the light): then the fastest
  /// feed at this speed that would give them.
  std::string WhyNoTrigger() const;

 private:
  struct Dip {
    double t = 0, share = 1, width_s = -1;
    bool confirmed = false;
    double x = std::numeric_limits<double>::quiet_NaN();  // from the raw samples' parabola
    double x_sigma = 0;                                   // its standard uncertainty
  };
  struct Fit {
    double a = 0, b = 0, rms = 0;  // x = a + b t
    int inliers = 0;
  };
  // The last kRing points (t, x) of a series and the line through most of them.
  struct Ring {
    std::array<double, kRing> t{}, x{};
    int n = 0, head = 0;
    void Push(double tt, double xx);
    double LastT() const { return t[static_cast<size_t>((head + kRing - 1) % kRing)]; }
    bool Line(double tol, double speed, double dir, Fit* fit) const;
  };
  struct Tooth {
    Ring extremes;  // (t, intrusion)
    Ring widths;    // (t, cos of half the dip's angle), for the band of the next width
    double st = 0, sy = 0, stt = 0, sty = 0;  // all the widths' regression sums
    int width_count = 0;
    double deep_t = -1e300;               // its last dip deeper than the curve's span
    std::array<double, kRing> x_sigma{};  // the extremes' uncertainties, as `extremes`
  };
  struct Intercept {  // a tooth's: where its line is at t = 0, and how well known
    double a = 0, sigma = 0, latest_t = 0, latest_x = 0;
    int inliers = 0;
  };

  void Smoothed(double share, double t);  // the extreme follower
  bool TurningTrigger(double now);        // true when it fired
  double RawCross(double level, bool falling, double smoothed_t) const;
  void FinishDip();
  void Schedule(const Dip& d);
  void AddToTooth(const Dip& d);
  void AddWidth(Tooth* th, const Dip& d);
  void UpdatePrediction();
  void UpdateFeedPrediction();  // with a curve: the feed's known slope
  bool ToothIntercept(const Tooth& th, Intercept* out) const;
  int MinimaNeeded() const;
  void DeepestPoint(Dip* d) const;
  void FollowClear(double y, double t);
  bool Dimmed(const Dip& d) const;
  void PinStep(double share, double t);
  bool RiseConfirms(double cross_t) const;
  void Reject(Rejected r, long sample);
  bool ClearLevel(float volts);  // without a curve: false while the clear level is measured
  bool ToothLine(const Tooth& th, Fit* fit) const;
  double ToIntrusion(double share) const;  // the curve's x, or z = erfcinv(2 share) without one

  ProcessorConfig cfg_;
  double clear_v_ = std::numeric_limits<double>::quiet_NaN();
  std::array<double, 64> clear_blocks_{};  // 1 ms means of the signal, for the clear level
  int clear_block_n_ = 0, clear_in_block_ = 0;
  double clear_block_sum_ = 0, deepest_share_ = 1;
  double width_due_t_ = std::numeric_limits<double>::quiet_NaN();
  int width_due_tooth_ = -1;
  double period_s_ = 0, x_threshold_ = 0, x_confirm_ = 0, feed_mm_s_ = 0, dir_ = 1;
  long n_ = 0;
  std::array<double, kSmooth> smooth_{};
  std::array<float, kRaw> raw_{};  // the last kRaw samples' volts
  double noise_share_ = 0.002;     // per sample: the clear level's scatter
  // The clear level followed between dips: a window after each dip, its mean.
  double clear_win_start_ = -1, clear_win_end_ = -1, clear_win_sum_ = 0, clear_win_sum2_ = 0;
  double clear_win_min_ = 2, clear_win_max_ = 0;
  long clear_win_n_ = 0;
  double smooth_sum_ = 0;
  // The extreme follower on the averaged signal.
  bool seeking_min_ = false;
  double max_ = -1, min_ = 2, min_t_ = 0, min_left_ = 0, min_right_ = 0, prev_ = 1, prev_t_ = 0;
  bool min_right_set_ = false;
  double down_t_ = -1, up_t_ = -1, pending_down_t_ = -1;
  Dip dip_;
  bool dip_open_ = false;
  // The schedule's ring of dips and the teeth.
  std::array<Dip, kRing> ring_{};
  int ring_n_ = 0, ring_head_ = 0;
  double t_ref_ = std::numeric_limits<double>::quiet_NaN();
  std::array<Tooth, kMaxTeeth> teeth_{};
  double due_t_ = std::numeric_limits<double>::quiet_NaN();
  double not_before_t_ = 0;  // every other tooth has passed the beam since the leader's minimum
  long next_review_ = 0;     // the sample at which the prediction is looked at again
  double due_sigma_mm_ = std::numeric_limits<double>::quiet_NaN();
  int due_tooth_ = -1, due_extremes_ = 0;
  Trigger trigger_;
  // Not turning: the slope window and the hold.
  std::array<double, kSlopeMax> slope_ring_{};
  int slope_n_ = 0;
  double cross_t_ = -1;
  double steep_t_ = -1;  // a fall through the threshold rejected as too steep (a drop?)
  RiseFinder rise_;
  double predicted_cross_t_ = std::numeric_limits<double>::quiet_NaN();
  bool rise_confirmed_ = false;
  std::array<int, 5> rejection_count_{};
  std::array<Rejection, 16> recent_{};
  int recent_n_ = 0;
};

}  // namespace mlp::setter
