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
  if (c.HasCurve()) clear_v_ = c.curve.clear_v;
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
  if (!Triggered() && cfg_.rpm > 0 && !std::isnan(due_t_) && now >= due_t_) {
    trigger_ = {n_,
                now,
                due_t_,
                dir_ * feed_mm_s_ * (now - due_t_),
                due_tooth_,
                due_extremes_,
                TriggerCause::kLine};
    fired = true;
  }
  if (!Triggered() && cfg_.rpm > 0 && !std::isnan(width_due_t_)) {
    trigger_ = {n_,
                now,
                width_due_t_,
                dir_ * feed_mm_s_ * (now - width_due_t_),
                width_due_tooth_,
                0,
                TriggerCause::kWidth};
    fired = true;
  }
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

// The extremes of the averaged share with a hysteresis: max, min (a dip opens), max (it
// closes); the width's crossings on the way down and up.
void BeamProcessor::Smoothed(double y, double t) {
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

void BeamProcessor::FinishDip() {
  if (down_t_ >= 0 && up_t_ > down_t_ && dip_.share < cfg_.width_share)
    dip_.width_s = up_t_ - down_t_;
  deepest_share_ = std::min(deepest_share_, dip_.share);
  dip_open_ = false;
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
  if (d.share >= lo && d.share <= hi) {
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
  const CalibrationCurve& c = cfg_.curve;
  const double x = x_threshold_;
  const double expected = (c.c[1] + x * (2 * c.c[2] + 3 * x * c.c[3])) * dir_ * feed_mm_s_;
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
  const double span_um = 1000 * (cfg_.curve.hi_mm - cfg_.curve.lo_mm);
  const double minima = span_um / per_turn_um;  // one per tooth per turn
  if (minima < cfg_.fit_min) {
    std::snprintf(text, sizeof text,
                  "at %.1f um a turn only %.1f of a tooth's minima fall in the curve's %.1f um "
                  "span, its line needs %d: at %.0f rpm a feed of at most %.1f mm/min",
                  per_turn_um, minima, span_um, cfg_.fit_min, cfg_.rpm,
                  std::floor(10 * span_um / cfg_.fit_min * cfg_.rpm / 1000) / 10);
    return text;
  }
  std::snprintf(text, sizeof text,
                "no tooth's minima made a line at the feed within %.1f um (a drop on every "
                "pass, a speed other than %.0f rpm, or a wrong tooth count)",
                1000 * cfg_.fit_tol_mm, cfg_.rpm);
  return text;
}

}  // namespace mlp::setter
