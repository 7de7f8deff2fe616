#include "mlp/setter/beam_processor.h"

#include "mlp/setter/beam_signal.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mlp::setter {
namespace {

[[noreturn]] void Fail(const std::string& what) {
  throw SetterInputError("beam processor: " + what);
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The band of a dip's width about its tooth's line, in cos(half its angle): its noise is
// about 1e-5 (half a microsecond on a crossing); a drop in the dip moves it by far more.
constexpr double kWidthBand = 2e-4;

// Where a straight line through (t0, y0) and (t1, y1) meets `level`.
double Cross(double t0, double y0, double t1, double y1, double level) {
  return y1 == y0 ? t1 : t0 + (t1 - t0) * (level - y0) / (y1 - y0);
}

}  // namespace

const char* ToString(TriggerCause c) {
  switch (c) {
    case TriggerCause::kLine:
      return "the leading tooth's line crossed the threshold";
    case TriggerCause::kWidth:
      return "a dip of the leading tooth reached the width set";
    case TriggerCause::kPin:
      return "the light held beyond the threshold";
    case TriggerCause::kRise:
      return "the light crossed the threshold when the rise p predicted";
  }
  return "?";
}

const char* ToString(Rejected r) {
  switch (r) {
    case Rejected::kOffSchedule:
      return "a dip off the teeth's schedule (a drop?)";
    case Rejected::kOutsideBand:
      return "an extreme outside its tooth's band";
    case Rejected::kTooSteep:
      return "a fall steeper than the calibration curve at the feed (a drop?)";
    case Rejected::kNotHeld:
      return "the light came back before the hold (a drop?)";
    case Rejected::kDimmed:
      return "a dip on a dimmed beam (its shoulders in a drop)";
  }
  return "?";
}

void ProcessorConfig::Validate() const {
  if (!(sample_rate_hz >= 10000 && sample_rate_hz <= 500000)) Fail("sample_rate_hz: 10..500 kHz");
  if (!(rpm >= 0 && rpm <= 60000) || teeth < 1 || teeth > BeamProcessor::kMaxTeeth)
    Fail("rpm 0..60000, teeth 1..16");
  if (!(feed_mm_min > 0)) Fail("feed_mm_min must be > 0");
  if (HasCurve()) {
    if (!(curve.hi_mm > curve.lo_mm)) Fail("the calibration curve has no span");
    if (!(threshold_share > curve.ShareLo() && threshold_share < curve.ShareHi()))
      Fail("the threshold must lie on the calibration curve's span");
    if (!(width_share > threshold_share && width_share < curve.ShareHi()))
      Fail("the width's share must lie between the threshold and the curve's top");
  } else {
    if (reflective)
      Fail("a reflective setter needs its calibration curve (its full reflection is the level)");
    if (!(clear_s >= 0.005 && clear_s <= 0.064))
      Fail("clear_s: 5..64 ms (the clear level without a curve)");
    if (!(line_share_lo > 0 && line_share_lo < threshold_share && threshold_share < line_share_hi &&
          line_share_hi < 1))
      Fail("without a curve: 0 < line_share_lo < threshold_share < line_share_hi < 1");
    if (!(width_share > threshold_share && width_share < 1))
      Fail("the width's share must lie between the threshold and 1");
    if (!(z_tol > 0) || !(z_band > 0)) Fail("z_tol and z_band must be > 0");
  }
  if (!(width_trigger_s >= 0)) Fail("width_trigger_s must be >= 0 (0: off)");
  if (!(amplifier_hz == 0 || (amplifier_hz >= 1000 && amplifier_hz <= 1e6)))
    Fail("amplifier_hz: 0 (unknown) or 1 kHz..1 MHz");
  if (!(scale_uncertainty >= 0 && scale_uncertainty < 0.5)) Fail("scale_uncertainty: 0..0.5");
  if (!(confirm_share > 0 && confirm_share < threshold_share &&
        threshold_share + confirm_share < 1))
    Fail("confirm_share must be > 0 and keep threshold +- it within (0, 1)");
  if (fit_min < 3 || fit_min > BeamProcessor::kRing || !(fit_tol_mm > 0) || !(band_mm > 0) ||
      !(gate_share > 0 && gate_share < 0.25) || !(hysteresis_share > 0) || !(hold_s > 0) ||
      !(drop_max_s > 0))
    Fail("fit_min 3..8; tolerances, gate (under 1/4), hysteresis, hold and drop_max_s > 0");
  if (rise_predicts && (rpm > 0 || !entering || reflective || !HasCurve() ||
                        !(curve.rise_share > 0) || !(rise_window_mm > 0)))
    Fail(
        "rise_predicts: a pin entering a transmissive setter, its curve with a rise, a window > 0");
}

BeamProcessor::BeamProcessor(const ProcessorConfig& c)
    : cfg_(c), rise_(c.curve.rise_share / 2, kRiseMinS) {
  c.Validate();
  if (c.rpm > 0) period_s_ = 60.0 / (c.rpm * c.teeth);
  // The clear level: the curve's for a pin (its slope test is the curve's), for a tool leaving
  // (dark at first) and for a reflective setter (its level is the full reflection); a tool
  // entering measures it first (the laser's power drifts from the calibration's), and every
  // tool then follows it between the dips.
  if (c.HasCurve() && (c.rpm == 0 || !c.entering || c.reflective)) clear_v_ = c.curve.clear_v;
  x_threshold_ = ToIntrusion(c.threshold_share);
  feed_mm_s_ = c.feed_mm_min / 60.0;
  dir_ = c.entering ? 1.0 : -1.0;
  // Entering, the shares fall towards the threshold; leaving, they rise towards it.
  x_confirm_ = ToIntrusion(c.threshold_share + dir_ * c.confirm_share);
}

// erfcinv(2 share) by Newton's method on erfc (no inverse in the standard library): from 0,
// six steps reach double precision for shares in [0.01, 0.99].
double Probit(double share) {
  const double target = 2.0 * std::clamp(share, 1e-6, 1.0 - 1e-6);
  double z = 0.0;
  for (int i = 0; i < 8; ++i) {
    const double slope = -2.0 / std::sqrt(M_PI) * std::exp(-z * z);
    const double step = (std::erfc(z) - target) / slope;
    z -= step;
    if (std::abs(step) < 1e-14) break;
  }
  return z;
}

double BeamProcessor::ToIntrusion(double share) const {
  return cfg_.HasCurve() ? cfg_.curve.IntrusionAt(share) : Probit(share);
}

// Without a curve the clear level is measured first: the median of 1 ms means (a drop in the
// window dims a few of them, not the median).
bool BeamProcessor::ClearLevel(float volts) {
  if (!std::isnan(clear_v_)) return true;
  const int per_block = std::max(1, static_cast<int>(0.001 * cfg_.sample_rate_hz));
  clear_block_sum_ += volts;
  if (++clear_in_block_ < per_block) return false;
  clear_blocks_[static_cast<size_t>(clear_block_n_++)] = clear_block_sum_ / per_block;
  clear_block_sum_ = 0, clear_in_block_ = 0;
  const int blocks = std::min(64, std::max(5, static_cast<int>(std::lround(cfg_.clear_s * 1000))));
  if (clear_block_n_ < blocks) return false;
  std::array<double, 64> sorted = clear_blocks_;
  std::nth_element(sorted.begin(), sorted.begin() + blocks / 2, sorted.begin() + blocks);
  clear_v_ = sorted[static_cast<size_t>(blocks / 2)];
  if (!(clear_v_ > 0)) {  // dark: measure again
    clear_v_ = std::numeric_limits<double>::quiet_NaN(), clear_block_n_ = 0;
    return false;
  }
  smooth_.fill(1.0), smooth_sum_ = kSmooth;  // the average starts at the clear level
  return false;
}

bool BeamProcessor::Push(float volts) {
  raw_[static_cast<size_t>(n_ % kRaw)] = volts;
  if (!ClearLevel(volts)) {
    ++n_;
    return false;
  }
  const double share = cfg_.reflective ? 1.0 - volts / clear_v_ : volts / clear_v_;
  const auto slot = static_cast<size_t>(n_ % kSmooth);
  smooth_sum_ += share - smooth_[slot];
  smooth_[slot] = share;
  bool fired = false;
  if (n_ >= kSmooth - 1) {
    const long middle = n_ - kSmooth / 2;  // the averaged window's middle sample (kSmooth odd)
    const double y = smooth_sum_ / kSmooth, t = static_cast<double>(middle) / cfg_.sample_rate_hz;
    if (cfg_.rpm > 0)
      Smoothed(y, t);
    else
      PinStep(y, t);
    prev_ = y, prev_t_ = t;
  }
  const double now = static_cast<double>(n_) / cfg_.sample_rate_hz;
  if (!Triggered() && cfg_.rpm > 0) fired = TurningTrigger(now);
  if (!Triggered() && cfg_.rpm == 0 && cross_t_ >= 0 &&
      (rise_confirmed_ || now - cross_t_ >= cfg_.hold_s)) {
    trigger_ = {n_,
                now,
                cross_t_,
                dir_ * feed_mm_s_ * (now - cross_t_),
                -1,
                0,
                rise_confirmed_ ? TriggerCause::kRise : TriggerCause::kPin,
                predicted_cross_t_};
    fired = true;
  }
  ++n_;
  return fired;
}

// A turning tool's trigger: its leading tooth's predicted crossing due, or a dip as wide as
// width_trigger_s.
bool BeamProcessor::TurningTrigger(double now) {
  if (cfg_.HasCurve() && n_ >= next_review_) {
    // The prediction's conditions change with time too (the leader's next pass gone by).
    next_review_ = n_ + std::max(1L, std::lround(0.25 * period_s_ * cfg_.sample_rate_hz));
    UpdateFeedPrediction();
  }
  if (!std::isnan(due_t_) && now >= due_t_ && now >= not_before_t_) {
    trigger_ = {n_,
                now,
                due_t_,
                dir_ * feed_mm_s_ * (now - due_t_),
                due_tooth_,
                due_extremes_,
                TriggerCause::kLine};
    trigger_.edge_sigma_mm = due_sigma_mm_;
    return true;
  }
  if (!std::isnan(width_due_t_)) {
    trigger_ = {n_,
                now,
                width_due_t_,
                dir_ * feed_mm_s_ * (now - width_due_t_),
                width_due_tooth_,
                0,
                TriggerCause::kWidth};
    return true;
  }
  return false;
}

// The extremes of the averaged share with a hysteresis: max, min (a dip opens), max (it
// closes); the width's crossings on the way down and up.
void BeamProcessor::Smoothed(double y, double t) {
  if (cfg_.HasCurve()) FollowClear(y, t);
  // A dip is done half a tooth period after its minimum (none is wider), not only when the
  // next one begins: a tool leaving the beam makes a last dip with none after it.
  if (dip_open_ && !seeking_min_ && t - dip_.t > 0.5 * period_s_) FinishDip();
  const double h = cfg_.hysteresis_share, w = cfg_.width_share;
  const bool down = prev_ >= w && y < w, up = prev_ < w && y >= w;
  if (down) {
    const double tc = RawCross(w, true, Cross(prev_t_, prev_, t, y, w));
    if (dip_open_)
      pending_down_t_ = tc;  // the next dip's, while this one waits for its second max
    else
      down_t_ = tc;
  }
  if (up && dip_open_ && up_t_ < 0) up_t_ = RawCross(w, false, Cross(prev_t_, prev_, t, y, w));
  if (!seeking_min_) {
    max_ = std::max(max_, y);
    if (y < max_ - h) {
      if (dip_open_) FinishDip();
      seeking_min_ = true;
      min_ = y, min_t_ = t, min_left_ = prev_, min_right_set_ = false;
    }
    return;
  }
  if (y < min_) {
    min_ = y, min_t_ = t, min_left_ = prev_, min_right_set_ = false;
  } else if (!min_right_set_) {
    min_right_ = y, min_right_set_ = true;
  }
  if (y > min_ + h && min_right_set_) {
    // The minimum between samples: a parabola through it and its neighbours.
    const double den = min_left_ - 2 * min_ + min_right_;
    const double off = den > 0 ? std::clamp(0.5 * (min_left_ - min_right_) / den, -0.5, 0.5) : 0;
    dip_ = {min_t_ + off / cfg_.sample_rate_hz, min_ - 0.25 * (min_left_ - min_right_) * off, -1,
            false};
    if (cfg_.HasCurve()) {
      DeepestPoint(&dip_);
      // The gap's middle after it, for the clear level.
      clear_win_start_ = dip_.t + 0.3 * period_s_, clear_win_end_ = dip_.t + 0.7 * period_s_;
      clear_win_sum_ = clear_win_sum2_ = 0, clear_win_n_ = 0;
      clear_win_min_ = 2, clear_win_max_ = 0;
    }
    dip_open_ = true, up_t_ = -1, pending_down_t_ = -1;
    seeking_min_ = false, max_ = y;
  }
}

// The width's crossings are found on the average (one per side, whatever the noise) but timed
// on the samples themselves, the pair straddling the level nearest it: the average's crossing
// moves with the dip's curvature, which changes as the tool goes in (it took 0.4 % off the
// radius from the widths).
double BeamProcessor::RawCross(double level, bool falling, double smoothed_t) const {
  double best = smoothed_t, best_gap = 1e300;
  for (long j = n_ - kSmooth + 1; j < n_; ++j) {
    const double a = smooth_[static_cast<size_t>(j % kSmooth)],
                 b = smooth_[static_cast<size_t>((j + 1) % kSmooth)];
    if (falling ? !(a >= level && b < level) : !(a < level && b >= level)) continue;
    const double tc = (static_cast<double>(j) + (a - level) / (a - b)) / cfg_.sample_rate_hz;
    if (std::abs(tc - smoothed_t) < best_gap) best = tc, best_gap = std::abs(tc - smoothed_t);
  }
  return best;
}

// The clear level between the dips: the averaged share over the middle of the gap after each
// dip (30-70 % of a tooth period on: the tooth is turned far from the beam), when no dip
// began in it and it stayed within 3 % of the level (a drop does not), moves the level a
// quarter of the way; its scatter (times 3: the average's) is the samples' noise.
void BeamProcessor::FollowClear(double y, double t) {
  if (clear_win_start_ < 0 || t < clear_win_start_) return;
  if (seeking_min_) {  // a dip began in the window
    clear_win_start_ = -1;
    return;
  }
  if (t <= clear_win_end_) {
    clear_win_sum_ += y, clear_win_sum2_ += y * y, ++clear_win_n_;
    clear_win_min_ = std::min(clear_win_min_, y), clear_win_max_ = std::max(clear_win_max_, y);
    return;
  }
  const double n = static_cast<double>(clear_win_n_);
  clear_win_start_ = -1;
  if (clear_win_n_ < 8 || clear_win_min_ < 0.97 || clear_win_max_ > 1.03) return;
  const double mean = clear_win_sum_ / n;
  const double var = std::max(0.0, clear_win_sum2_ / n - mean * mean);
  clear_v_ *= 1 + 0.25 * (mean - 1);
  noise_share_ = std::clamp(3 * std::sqrt(var), 1e-4, 0.05);
}

// A tooth's dip has the clear beam a quarter of a tooth period either side (the tooth turned
// away); a drop's dimming spans it. The shoulders: 9 raw samples' mean there, under 1 - 3
// hysteresis. A shoulder no longer (or not yet) in the ring is not judged.
bool BeamProcessor::Dimmed(const Dip& d) const {
  const double fs = cfg_.sample_rate_hz;
  const long m = std::lround(d.t * fs), q = std::lround(0.25 * period_s_ * fs);
  const long oldest = std::max(0L, n_ - kRaw + 1);
  for (const long c : {m - q, m + q}) {
    if (c - 4 < oldest || c + 4 > n_) continue;
    double sum = 0;
    for (long i = c - 4; i <= c + 4; ++i) sum += raw_[static_cast<size_t>(i % kRaw)];
    const double share = sum / 9 / clear_v_;
    if ((cfg_.reflective ? 1.0 - share : share) < 1 - 3 * cfg_.hysteresis_share) return true;
  }
  return false;
}

void BeamProcessor::FinishDip() {
  if (down_t_ >= 0 && up_t_ > down_t_ && dip_.share < cfg_.width_share)
    dip_.width_s = up_t_ - down_t_;
  deepest_share_ = std::min(deepest_share_, dip_.share);
  dip_open_ = false;
  if (cfg_.HasCurve() && dip_.share >= cfg_.curve.ShareLo() && Dimmed(dip_)) {
    Reject(Rejected::kDimmed, std::lround(dip_.t * cfg_.sample_rate_hz));
    down_t_ = pending_down_t_, up_t_ = -1, pending_down_t_ = -1;
    return;
  }
  down_t_ = pending_down_t_, up_t_ = -1, pending_down_t_ = -1;
  Schedule(dip_);
}

// A dip counts when at least two of the last dips lie whole tooth periods before it; those
// are confirmed with it. A dip that leaves the ring unconfirmed was not the tool's.
void BeamProcessor::Schedule(const Dip& d) {
  std::array<bool, kRing> supports{};
  int support = 0;
  for (int i = 0; i < ring_n_; ++i) {
    const Dip& r = ring_[static_cast<size_t>((ring_head_ + i) % kRing)];
    const double k = (d.t - r.t) / period_s_, m = std::round(k);
    if (m >= 1 && std::abs(k - m) < cfg_.gate_share)
      supports[static_cast<size_t>(i)] = true, ++support;
  }
  Dip in = d;
  if (support >= 2) {
    for (int i = 0; i < ring_n_; ++i) {  // oldest first
      Dip& r = ring_[static_cast<size_t>((ring_head_ + i) % kRing)];
      if (supports[static_cast<size_t>(i)] && !r.confirmed) r.confirmed = true, AddToTooth(r);
    }
    in.confirmed = true;
    AddToTooth(in);
  }
  if (ring_n_ == kRing) {
    const Dip& out = ring_[static_cast<size_t>(ring_head_)];
    if (!out.confirmed) {
      const long at = static_cast<long>(std::lround(out.t * cfg_.sample_rate_hz));
      Reject(Rejected::kOffSchedule, at);
    }
    ring_[static_cast<size_t>(ring_head_)] = in;
    ring_head_ = (ring_head_ + 1) % kRing;
  } else {
    ring_[static_cast<size_t>((ring_head_ + ring_n_) % kRing)] = in;
    ++ring_n_;
  }
}

// The line through most of the tooth's extremes (every pair's line, its points within `tol`,
// the best then fitted by least squares): a drop that came in on the schedule is outvoted.
// `speed` > 0: only lines moving at +-50 % of it along `dir`.
void BeamProcessor::Ring::Push(double tt, double xx) {
  t[static_cast<size_t>(head)] = tt, x[static_cast<size_t>(head)] = xx;
  head = (head + 1) % kRing, n = std::min(n + 1, kRing);
}

bool BeamProcessor::Ring::Line(double tol, double speed, double dir, Fit* fit) const {
  if (n < 2) return false;
  unsigned best = 0;
  int best_count = 0;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double ti = t[static_cast<size_t>(i)], tj = t[static_cast<size_t>(j)];
      if (ti == tj) continue;
      const double b = (x[static_cast<size_t>(j)] - x[static_cast<size_t>(i)]) / (tj - ti);
      if (speed > 0 && !(b * dir > 0.5 * speed && b * dir < 1.5 * speed)) continue;
      const double a = x[static_cast<size_t>(i)] - b * ti;
      unsigned mask = 0;
      int count = 0;
      for (int k = 0; k < n; ++k)
        if (std::abs(x[static_cast<size_t>(k)] - (a + b * t[static_cast<size_t>(k)])) <= tol)
          mask |= 1u << k, ++count;
      if (count > best_count) best = mask, best_count = count;
    }
  if (best_count < 2) return false;
  double mt = 0, mx = 0;
  for (int k = 0; k < n; ++k)
    if (best >> k & 1u) mt += t[static_cast<size_t>(k)], mx += x[static_cast<size_t>(k)];
  mt /= best_count, mx /= best_count;
  double stt_ = 0, stx = 0;
  for (int k = 0; k < n; ++k)
    if (best >> k & 1u) {
      const double dt = t[static_cast<size_t>(k)] - mt;
      stt_ += dt * dt, stx += dt * (x[static_cast<size_t>(k)] - mx);
    }
  if (!(stt_ > 0)) return false;
  fit->b = stx / stt_, fit->a = mx - fit->b * mt, fit->inliers = best_count;
  double ss = 0;
  for (int k = 0; k < n; ++k)
    if (best >> k & 1u)
      ss += std::pow(x[static_cast<size_t>(k)] - (fit->a + fit->b * t[static_cast<size_t>(k)]), 2);
  fit->rms = std::sqrt(ss / best_count);
  return true;
}

void BeamProcessor::AddToTooth(const Dip& d) {
  if (std::isnan(t_ref_)) t_ref_ = d.t;
  const long turns = std::lround((d.t - t_ref_) / period_s_);
  const int k = static_cast<int>(((turns % cfg_.teeth) + cfg_.teeth) % cfg_.teeth);
  Tooth& th = teeth_[static_cast<size_t>(k)];
  const long at = std::lround(d.t * cfg_.sample_rate_hz);
  // The span where a minimum is on its tooth's line: the curve's, or the near-linear one.
  const double lo = cfg_.HasCurve() ? cfg_.curve.ShareLo() : cfg_.line_share_lo;
  const double hi = cfg_.HasCurve() ? cfg_.curve.ShareHi() : cfg_.line_share_hi;
  const double band = cfg_.HasCurve() ? cfg_.band_mm : cfg_.z_band;
  if (d.share < lo) th.deep_t = d.t;  // in further than the line reaches
  if (cfg_.HasCurve() && d.share >= lo && d.share <= hi) {
    const double x = std::isfinite(d.x) ? d.x : ToIntrusion(d.share);
    // No better than one sample's noise through the curve's slope: the fit's residuals miss
    // what all its samples share (the curve's bins, the clear level, a drop's edge).
    const double one_sample = noise_share_ / std::max(1e-3, std::abs(cfg_.curve.Slope(x)));
    const double sigma = std::isfinite(d.x) ? std::max(d.x_sigma, one_sample) : one_sample;
    Intercept ic;
    if (ToothIntercept(th, &ic) && ic.inliers >= 2 &&
        std::abs(x - dir_ * feed_mm_s_ * d.t - ic.a) > band) {
      Reject(Rejected::kOutsideBand, at);
      return;
    }
    th.x_sigma[static_cast<size_t>(th.extremes.head)] = sigma;
    th.extremes.Push(d.t, x);
  } else if (d.share >= lo && d.share <= hi) {
    const double x = ToIntrusion(d.share);
    // The band needs a line to hold: 3 extremes at the feed with a curve; without one (no
    // speed to check a line against) fit_min, or a drop among the first 3 would lock the
    // tooth's good minima out.
    const int hold = cfg_.HasCurve() ? 3 : cfg_.fit_min;
    Fit f;
    if (th.extremes.n >= hold && ToothLine(th, &f) && f.inliers >= hold &&
        std::abs(x - (f.a + f.b * d.t)) > band) {
      Reject(Rejected::kOutsideBand, at);
      return;
    }
    th.extremes.Push(d.t, x);
  }
  if (d.width_s > 0 && d.width_s < 0.5 * period_s_) {
    AddWidth(&th, d);
    if (cfg_.width_trigger_s > 0 && d.width_s >= cfg_.width_trigger_s && std::isnan(width_due_t_) &&
        (k == due_tooth_ || due_tooth_ < 0))
      width_due_t_ = d.t, width_due_tooth_ = k;
  }
  UpdatePrediction();
}

// y = cos(half the dip's angle) = (x_w - axis) / r falls with the axis at the feed over r.
// A width goes into the regression's sums when it leaves the tooth's ring of the last widths
// as one of the ring's line's, within kWidthBand: a dip a drop crossed, or whose fall a drop
// began, is left out.
void BeamProcessor::AddWidth(Tooth* th, const Dip& d) {
  const double y = std::cos(M_PI * cfg_.rpm / 60 * d.width_s), tt = d.t - t_ref_;
  Ring& r = th->widths;
  Fit f;
  if (r.n == kRing && r.Line(kWidthBand, 0, dir_, &f) && f.inliers >= 4) {
    const double t0 = r.t[static_cast<size_t>(r.head)], y0 = r.x[static_cast<size_t>(r.head)];
    if (std::abs(y0 - (f.a + f.b * t0)) <= kWidthBand)
      th->st += t0, th->sy += y0, th->stt += t0 * t0, th->sty += t0 * y0, ++th->width_count;
  }
  r.Push(tt, y);
}

// A tooth's line: intrusions at the feed (+-50 %) with a curve; without one, shares falling
// in the approach's sense (their rate in share is not known beforehand).
bool BeamProcessor::ToothLine(const Tooth& th, Fit* fit) const {
  if (cfg_.HasCurve()) return th.extremes.Line(cfg_.band_mm, feed_mm_s_, dir_, fit);
  return th.extremes.Line(cfg_.z_band, 0, dir_, fit) && fit->b * dir_ > 0;
}

// The leading tooth (the furthest in now, among those with a line at the feed through two
// extremes or more) triggers once its line holds `fit_min` extremes within `fit_tol_mm`: when
// it crosses the threshold. A tooth ahead with too few extremes yet (drops spoiled its dips)
// holds the trigger back rather than let a shorter tooth fire it.
void BeamProcessor::UpdatePrediction() {
  if (cfg_.HasCurve()) {
    UpdateFeedPrediction();
    return;
  }
  const double now = static_cast<double>(n_) / cfg_.sample_rate_hz;
  double best = -1e300;
  Fit lead;
  int lead_k = -1;
  for (int k = 0; k < cfg_.teeth; ++k) {
    Fit f;
    if (!ToothLine(teeth_[static_cast<size_t>(k)], &f)) continue;
    if (f.a + f.b * now > best) best = f.a + f.b * now, lead = f, lead_k = k;
  }
  due_t_ = kNaN, due_tooth_ = lead_k;
  const double tol = cfg_.HasCurve() ? cfg_.fit_tol_mm : cfg_.z_tol;
  if (lead_k < 0 || lead.inliers < cfg_.fit_min || lead.rms > tol) return;
  // Extrapolate only from near the threshold (a thin tool's dips stop short of it).
  const Ring& ring = teeth_[static_cast<size_t>(lead_k)].extremes;
  const double latest = ring.x[static_cast<size_t>((ring.head + kRing - 1) % kRing)];
  if (dir_ * (latest - x_confirm_) < 0) return;
  // A tooth that went in further than the curve reaches within the turns a line needs is
  // ahead of, or not yet comparable with, the leader (leaving the beam, the longest tooth
  // comes onto the curve last): wait for its line.
  for (int k = 0; k < cfg_.teeth; ++k)
    if (k != lead_k &&
        now - teeth_[static_cast<size_t>(k)].deep_t < (cfg_.fit_min + 1) * cfg_.teeth * period_s_)
      return;
  due_t_ = (x_threshold_ - lead.a) / lead.b, due_extremes_ = lead.inliers;
}

// How many of a tooth's minima its intercept needs: as many as the feed per turn lets into
// the curve's span where dips show (under 1 - 2 hysteresis, down to the table's end), at most
// fit_min.
// 0 when a turn's advance exceeds the span: a tooth may pass it unseen, the longest among them.
int BeamProcessor::MinimaNeeded() const {
  const double advance_mm = feed_mm_s_ * 60.0 / cfg_.rpm;
  const double span_mm = cfg_.curve.hi_mm - cfg_.curve.IntrusionAt(1 - 2 * cfg_.hysteresis_share);
  return std::min(static_cast<int>(std::floor(span_mm / advance_mm)), cfg_.fit_min);
}

// A tooth's intercept with the feed's slope: the largest group of its minima whose intercepts
// agree within band_mm, their weighted mean (weights: the minimum's own uncertainty and the
// curve's scale uncertainty over its distance from the threshold).
bool BeamProcessor::ToothIntercept(const Tooth& th, Intercept* out) const {
  const Ring& r = th.extremes;
  if (r.n == 0) return false;
  const double v = dir_ * feed_mm_s_;
  // One uncertainty for all its minima, their rms: a minimum's own estimate scatters too much
  // to weight by (the generator's seed case: sd 0.089 um weighted by each one's, 0.059 by the rms).
  double s2 = 0;
  for (int i = 0; i < r.n; ++i)
    s2 += std::pow(std::max(th.x_sigma[static_cast<size_t>(i)], 5e-5), 2);
  s2 /= r.n;
  std::array<double, kRing> a{}, w{};
  for (int i = 0; i < r.n; ++i) {
    const auto k = static_cast<size_t>(i);
    a[k] = r.x[k] - v * r.t[k];
    const double scale = cfg_.scale_uncertainty * (r.x[k] - x_threshold_);
    w[k] = 1.0 / (s2 + scale * scale);
  }
  int best = -1, best_count = 0;
  double best_w = 0;
  for (int i = 0; i < r.n; ++i) {
    int count = 0;
    double sw = 0;
    for (int j = 0; j < r.n; ++j)
      if (std::abs(a[static_cast<size_t>(j)] - a[static_cast<size_t>(i)]) <= cfg_.band_mm)
        ++count, sw += w[static_cast<size_t>(j)];
    if (count > best_count || (count == best_count && sw > best_w))
      best = i, best_count = count, best_w = sw;
  }
  double sa = 0, sw = 0;
  *out = {};
  out->latest_t = -1e300;
  for (int j = 0; j < r.n; ++j) {
    const auto k = static_cast<size_t>(j);
    if (std::abs(a[k] - a[static_cast<size_t>(best)]) > cfg_.band_mm) continue;
    sa += w[k] * a[k], sw += w[k], ++out->inliers;
    if (r.t[k] > out->latest_t) out->latest_t = r.t[k], out->latest_x = r.x[k];
  }
  out->a = sa / sw, out->sigma = 1.0 / std::sqrt(sw);
  return true;
}

// With a curve: the leading tooth (the largest intercept) fires once it has the minima the
// feed per turn allows, one of them near the threshold, and every other tooth is on the curve
// or has passed the beam since its latest (one unseen in the span then reaches less); a tooth
// gone deeper than the curve within the last turns holds it back (its line is not comparable).
void BeamProcessor::UpdateFeedPrediction() {
  const double now = static_cast<double>(n_) / cfg_.sample_rate_hz;
  Intercept lead;
  int lead_k = -1;
  for (int k = 0; k < cfg_.teeth; ++k) {
    Intercept ic;
    if (ToothIntercept(teeth_[static_cast<size_t>(k)], &ic) && (lead_k < 0 || ic.a > lead.a))
      lead = ic, lead_k = k;
  }
  due_t_ = kNaN, due_tooth_ = lead_k;
  const double turn_s = period_s_ * cfg_.teeth;
  // The leader's next pass gone by without a minimum: what it has is all there will be.
  const bool passed = lead_k >= 0 && now > lead.latest_t + turn_s + 0.5 * period_s_;
  const int need = MinimaNeeded();
  if (need < 1 || lead_k < 0 || lead.inliers < std::max(1, need - (passed ? 1 : 0))) return;
  // A minimum within confirm_share of the threshold, or past it: a tool thinner than the beam
  // stops short, and is not extrapolated into a trigger.
  if (dir_ * (lead.latest_x - x_confirm_) < 0) return;
  // A tooth gone deeper than the curve lately, without an intercept of its own or beyond what
  // its intercept says, may be ahead of the leader: wait for it.
  for (int k = 0; k < cfg_.teeth; ++k) {
    const Tooth& th = teeth_[static_cast<size_t>(k)];
    if (k == lead_k || now - th.deep_t >= 2 * turn_s) continue;
    Intercept ic;
    const double v = dir_ * feed_mm_s_;
    if (!ToothIntercept(th, &ic) || ic.a + v * th.deep_t < cfg_.curve.hi_mm - cfg_.band_mm) return;
  }
  const double v = dir_ * feed_mm_s_;
  due_t_ = (x_threshold_ - lead.a) / v, due_extremes_ = lead.inliers;
  due_sigma_mm_ = lead.sigma;
  // A tooth not yet seen on the curve may be the longest: wait until every one has passed the
  // beam since the leader's latest minimum (one still unseen then reaches less).
  bool all_seen = true;
  for (int k = 0; k < cfg_.teeth; ++k) {
    Intercept ic;
    all_seen = all_seen && ToothIntercept(teeth_[static_cast<size_t>(k)], &ic);
  }
  not_before_t_ = all_seen ? 0.0 : lead.latest_t + (cfg_.teeth - 1 + 0.5) * period_s_;
}

namespace {

// The reach of a tooth past its deepest point, as the dip's samples show it: flat while the
// tooth's land faces the beam (a circular arc at the tooth's radius), then falling with the
// square of the turn on either side (the cutting edge ahead, the relief's start behind):
// x(s) = x0 - k max(0, |s - c| - half_flat)^2. For a given (c, half_flat) x0 and k are linear:
// least squares. A parabola through a land's flat top overshoots it by ~0.1 of the window's
// depth (0.1-0.15 um on the outside simulator's D10-D16 lands, all one way).
struct FlatTop {
  double x0 = 0, k = 0, sse = 1e300;
};

FlatTop FitFlatTop(const double* s, const double* x, int n, double c, double half_flat) {
  double sg = 0, sgg = 0, sx = 0, sgx = 0;
  for (int i = 0; i < n; ++i) {
    const double d = std::max(0.0, std::abs(s[i] - c) - half_flat), g = d * d;
    sg += g, sgg += g * g, sx += x[i], sgx += g * x[i];
  }
  const double det = n * sgg - sg * sg;
  FlatTop f;
  if (!(det > 0)) return f;
  // x = x0 - k g: normal equations for (x0, -k)
  f.x0 = (sgg * sx - sg * sgx) / det;
  f.k = -(n * sgx - sg * sx) / det;
  if (!(f.k > 0)) return FlatTop{};
  f.sse = 0;
  for (int i = 0; i < n; ++i) {
    const double d = std::max(0.0, std::abs(s[i] - c) - half_flat);
    f.sse += std::pow(x[i] - f.x0 + f.k * d * d, 2);
  }
  return f;
}

// The best (c, half_flat): first on a coarse grid (c within 3 samples of the window's centre of
// depth, half_flat up to half the window in at most 20 steps), then in tenths round the best.
// A grid and not a solver: the sse is not smooth in half_flat (samples enter the flat one by
// one), and ~400 small fits a dip keep the processor at ~tens of millions of samples a second.
FlatTop BestFlatTop(const double* s, const double* x, int n) {
  double lowest = x[0];
  for (int i = 1; i < n; ++i) lowest = std::min(lowest, x[i]);
  double sw = 0, swc = 0;
  for (int i = 0; i < n; ++i) sw += x[i] - lowest, swc += (x[i] - lowest) * s[i];
  const double centre = sw > 0 ? swc / sw : (s[0] + s[n - 1]) / 2;
  const double half = (s[n - 1] - s[0]) / 2, l_step = std::max(0.5, half / 20);
  FlatTop best;
  double best_c = centre, best_l = 0;
  const auto search = [&](double c0, double c1, double c_step, double l0, double l1, double step) {
    for (double c = c0; c <= c1 + 1e-9; c += c_step)
      for (double l = std::max(0.0, l0); l <= l1 + 1e-9; l += step) {
        const FlatTop f = FitFlatTop(s, x, n, c, l);
        if (f.sse < best.sse) best = f, best_c = c, best_l = l;
      }
  };
  search(centre - 3, centre + 3, 0.5, 0.0, half, l_step);
  search(best_c - 0.5, best_c + 0.5, 0.1, best_l - l_step, best_l + l_step, 0.1 * l_step);
  return best;
}

}  // namespace

// A dip's deepest point from the raw samples round the average's minimum (min_t_): each
// sample's share with the amplifier's first-order lag undone (u = y + tau dy/dt, central
// difference), through the curve into intrusion; the samples whose 3-sample mean lies within
// 1.5 um of the average's deepest (4 um when that leaves under 7), the flat-topped fit above
// through them, its top. Left NaN when the samples round it are not in the ring, off the
// curve, or fit no flat top that falls on both sides.
void BeamProcessor::DeepestPoint(Dip* d) const {
  const double fs = cfg_.sample_rate_hz;
  const long m = std::lround(min_t_ * fs), oldest = std::max(0L, n_ - kRaw + 1);
  const double tau_fs = cfg_.amplifier_hz > 0 ? fs / (2 * M_PI * cfg_.amplifier_hz) : 0.0;
  const auto share = [&](long i) {
    const double v = raw_[static_cast<size_t>(i % kRaw)] / clear_v_;
    return cfg_.reflective ? 1.0 - v : v;
  };
  const auto x_at = [&](long i) {
    const double u = share(i) + tau_fs * 0.5 * (share(i + 1) - share(i - 1));
    if (u > cfg_.curve.ShareHi() || u < cfg_.curve.ShareLo()) return kNaN;
    return cfg_.curve.IntrusionAt(u);
  };
  if (m - 1 <= oldest || m + 2 > n_) return;
  const double top = ToIntrusion(min_);
  constexpr int kMaxWindow = 256;
  for (const double band : {0.0015, 0.004}) {
    const auto inside = [&](long i) {
      if (i - 2 < oldest || i + 2 > n_) return false;
      const double x = (x_at(i - 1) + x_at(i) + x_at(i + 1)) / 3;  // NaN off the curve: out
      return x >= top - band;
    };
    long lo = m, hi = m;
    while (hi - lo < kMaxWindow - 1 && inside(lo - 1)) --lo;
    while (hi - lo < kMaxWindow - 1 && inside(hi + 1)) ++hi;
    if (hi - lo + 1 < 7 && band < 0.004) continue;
    std::array<double, kMaxWindow> sv{}, xv{};
    int n = 0;
    for (long i = lo; i <= hi; ++i) {
      const double x = x_at(i);
      if (!std::isfinite(x)) continue;
      sv[static_cast<size_t>(n)] = static_cast<double>(i - m), xv[static_cast<size_t>(n)] = x, ++n;
    }
    if (n < 5) return;
    const FlatTop f = BestFlatTop(sv.data(), xv.data(), n);
    if (!(f.sse < 1e300)) return;
    d->x = f.x0;
    // Its uncertainty: the residuals' rms over the samples at the top (about three
    // parameters' worth of them pin it).
    d->x_sigma = std::sqrt(f.sse / std::max(1, n - 4)) * std::sqrt(3.0 / n);
    return;
  }
}

// Not turning: the threshold's crossing, its slope against the curve's at the feed, the hold.
// The crossing at `cross_t` came where the rise said (NaN before a rise: never).
bool BeamProcessor::RiseConfirms(double cross_t) const {
  return std::abs(cross_t - predicted_cross_t_) * feed_mm_s_ <= cfg_.rise_window_mm;
}

void BeamProcessor::PinStep(double y, double t) {
  const int m = std::min(kSlopeMax, static_cast<int>(0.001 * cfg_.sample_rate_hz));
  const double then = slope_ring_[static_cast<size_t>(slope_n_ % m)];
  slope_ring_[static_cast<size_t>(slope_n_ % m)] = y;
  ++slope_n_;
  const double th = cfg_.threshold_share;
  const bool beyond = cfg_.entering ? y < th : y >= th;
  if (cross_t_ >= 0 && !Triggered() && !beyond) {
    Reject(Rejected::kNotHeld, n_);
    cross_t_ = -1;
  }
  if (cfg_.rise_predicts && rise_.Add(t, y))  // the pin's edge is due at the threshold then
    predicted_cross_t_ = rise_.PeakTimeS() + (x_threshold_ - cfg_.curve.rise_mm) / feed_mm_s_;
  deepest_share_ = std::min(deepest_share_, y);
  if (!beyond) steep_t_ = -1;  // the light came back: whatever fell was a drop
  if (cfg_.HasCurve() && steep_t_ >= 0 && cross_t_ < 0 && !Triggered() &&
      t - steep_t_ >= cfg_.drop_max_s) {  // beyond for longer than a drop: the pin crossed
    cross_t_ = t - std::abs(ToIntrusion(y) - x_threshold_) / feed_mm_s_;
    steep_t_ = -1;
    rise_confirmed_ = RiseConfirms(cross_t_);
    return;
  }
  const bool was_beyond = cfg_.entering ? prev_ < th : prev_ >= th;
  if (cross_t_ >= 0 || Triggered() || !beyond || was_beyond || slope_n_ <= m) return;
  if (!cfg_.HasCurve()) {  // no slope to compare: the hold alone
    cross_t_ = Cross(prev_t_, prev_, t, y, th);
    return;
  }
  const double expected = cfg_.curve.Slope(x_threshold_) * dir_ * feed_mm_s_;
  const double measured = (y - then) * cfg_.sample_rate_hz / m;
  if (std::abs(measured) > 3 * std::abs(expected) + 2 * cfg_.hysteresis_share * 1000 / m) {
    Reject(Rejected::kTooSteep, n_);
    steep_t_ = t;
    return;
  }
  cross_t_ = Cross(prev_t_, prev_, t, y, th);
  rise_confirmed_ = RiseConfirms(cross_t_);
}

void BeamProcessor::Reject(Rejected r, long sample) {
  ++rejection_count_[static_cast<size_t>(r)];
  recent_[static_cast<size_t>(recent_n_ % 16)] = {sample, r};
  ++recent_n_;
}

std::array<Rejection, 16> BeamProcessor::RecentRejections(int* count) const {
  std::array<Rejection, 16> out{};
  *count = std::min(recent_n_, 16);
  for (int i = 0; i < *count; ++i)
    out[static_cast<size_t>(i)] = recent_[static_cast<size_t>((recent_n_ - *count + i) % 16)];
  return out;
}

int BeamProcessor::LeadingTooth() const { return due_tooth_; }

double BeamProcessor::ToothRadiusMm() const {
  if (due_tooth_ < 0) return kNaN;
  const Tooth& th = teeth_[static_cast<size_t>(due_tooth_)];
  double st = th.st, sy = th.sy, stt = th.stt, sty = th.sty, n = th.width_count;
  Fit f;  // and the widths still in the ring, on its line
  if (th.widths.Line(kWidthBand, 0, dir_, &f))
    for (int i = 0; i < th.widths.n; ++i) {
      const double t = th.widths.t[static_cast<size_t>(i)], y = th.widths.x[static_cast<size_t>(i)];
      if (std::abs(y - (f.a + f.b * t)) > kWidthBand) continue;
      st += t, sy += y, stt += t * t, sty += t * y, ++n;
    }
  const double den = n * stt - st * st;
  if (n < 3 || !(den > 0)) return kNaN;
  const double slope = (n * sty - st * sy) / den;  // of cos(half the dip's angle)
  return slope != 0 ? -dir_ * feed_mm_s_ / slope : kNaN;
}

double BeamProcessor::ToothLagMm(int k) const {
  if (due_tooth_ < 0 || k < 0 || k >= cfg_.teeth) return kNaN;
  const Tooth& lead = teeth_[static_cast<size_t>(due_tooth_)];
  const Tooth& other = teeth_[static_cast<size_t>(k)];
  if (cfg_.HasCurve()) {  // the intercepts' difference, at the feed's slope
    Intercept i0, i1;
    if (!ToothIntercept(lead, &i0) || !ToothIntercept(other, &i1)) return kNaN;
    return i0.a - i1.a;
  }
  Fit f0, f1;
  if (!ToothLine(lead, &f0) || !ToothLine(other, &f1)) return kNaN;
  if (!cfg_.HasCurve())  // in share, not mm: how much later it crosses the threshold, at the feed
    return feed_mm_s_ * ((x_threshold_ - f1.a) / f1.b - (x_threshold_ - f0.a) / f0.b);
  const double t = lead.extremes.LastT();
  return (f0.a + f0.b * t) - (f1.a + f1.b * t);
}

std::string BeamProcessor::WhyNoTrigger() const {
  if (Triggered()) return "";
  char text[400];
  if (deepest_share_ > cfg_.threshold_share) {
    std::snprintf(text, sizeof text,
                  "the deepest dip left %.1f %% of the light (over the threshold: a tool thinner "
                  "than the beam, or one that never reached it; the threshold is %.1f %%)",
                  100 * deepest_share_, 100 * cfg_.threshold_share);
    return text;
  }
  if (cfg_.rpm <= 0) return "the crossing was not held (a drop?) or came too steep for the feed";
  const double per_turn_um = 1000 * cfg_.feed_mm_min / cfg_.rpm;
  if (!cfg_.HasCurve()) {
    std::snprintf(text, sizeof text,
                  "at %.1f um a turn too few of a tooth's minima fell between %.0f %% and "
                  "%.0f %% of the light for its line (%d); a slower feed gives more",
                  per_turn_um, 100 * cfg_.line_share_hi, 100 * cfg_.line_share_lo, cfg_.fit_min);
    return text;
  }
  const double span_um =
      1000 * (cfg_.curve.hi_mm - cfg_.curve.IntrusionAt(1 - 2 * cfg_.hysteresis_share));
  const double minima = span_um / per_turn_um;  // one per tooth per turn
  if (minima < 1) {
    std::snprintf(text, sizeof text,
                  "at %.1f um a turn a tooth's minima can miss the curve's %.1f um span where "
                  "dips show: at %.0f rpm a feed of at most %.1f mm/min (80 %% of a span a turn)",
                  per_turn_um, span_um, cfg_.rpm,
                  std::floor(10 * 0.8 * span_um * cfg_.rpm / 1000) / 10);
    return text;
  }
  std::snprintf(text, sizeof text,
                "no tooth's minima agreed within %.1f um at the feed's slope (a drop on every "
                "pass, a speed other than %.0f rpm, a wrong tooth count or feed)",
                1000 * cfg_.band_mm, cfg_.rpm);
  return text;
}

}  // namespace mlp::setter
