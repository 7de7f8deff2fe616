#include "mlp/toolcam/strobe.h"

#include <cmath>
#include <numeric>
#include <sstream>

namespace mlp::toolcam {
namespace {

[[noreturn]] void Refuse(const std::string& why) { throw StrobeError("strobe plan: " + why); }

std::string Fmt(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

void Check(const StrobeRequest& r) {
  const auto positive = [](double v, const char* what) {
    if (!(v > 0) || !std::isfinite(v)) Refuse(std::string(what) + " must be a positive number");
  };
  positive(r.rpm, "rpm");
  positive(r.frame_rate_hz, "the frame rate");
  positive(r.resolution_deg, "the angular resolution");
  positive(r.timer_resolution_us, "the timer resolution");
  positive(r.min_pulse_us, "the shortest pulse");
  positive(r.max_duration_s, "the longest coverage time");
  if (!(r.blanking_us >= 0) || !(r.rpm_tolerance >= 0) || r.max_pulses_per_image < 1)
    Refuse("blanking, speed tolerance must be >= 0 and pulses per image >= 1");
  if (!(r.pulse_share > 0 && r.pulse_share <= 1)) Refuse("the pulse's share must be in (0, 1]");
}

double Frac(double x) { return x - std::floor(x); }

// The step (positions advanced per image) nearest `natural` that visits every one of n
// positions (coprime with n), and the speed at which the advance per frame is exactly it:
// (whole revolutions per frame + step / n) revolutions per frame. Throws when that speed is
// further than the tolerance from the one asked for.
int CoveringStep(const StrobeRequest& r, int n, double* rps) {
  const double revs_per_frame = *rps / r.frame_rate_hz;
  const double whole = std::floor(revs_per_frame);
  const double natural = (revs_per_frame - whole) * n;
  int best = 0;
  double best_off = 1e300;
  for (int s = 1; s < n || (n == 1 && s == 1); ++s) {
    if (std::gcd(s, n) != 1) continue;
    const double off = std::abs(s - natural);
    if (off < best_off) best = s, best_off = off;
    if (n == 1) break;
  }
  const double exact_rps = (whole + static_cast<double>(best) / n) * r.frame_rate_hz;
  if (std::abs(exact_rps / *rps - 1) > r.rpm_tolerance + 1e-12)
    Refuse("at " + Fmt(r.rpm, 1) + " rpm the tool advances " + Fmt(natural, 3) +
           " positions per image; the nearest step that covers all " + std::to_string(n) +
           " positions needs " + Fmt(exact_rps * 60, 2) + " rpm, beyond the allowed change");
  *rps = exact_rps;
  return best;
}

// The positions one revolution is cut into: 360 deg must be a whole number of steps.
int PositionCount(const StrobeRequest& r) {
  const double n_real = 360.0 / r.resolution_deg;
  const int n = static_cast<int>(std::lround(n_real));
  if (std::abs(n_real - n) > 1e-9 * n_real || n < 1)
    Refuse("360 deg is not a whole number of " + Fmt(r.resolution_deg, 4) + " deg steps");
  return n;
}

// The pulse: a share of one step's time on the timer's grid, no longer than the window.
double PulseWidthUs(const StrobeRequest& r, const StrobePlan& p, double window_us) {
  double width_us =
      std::floor(r.pulse_share * p.step_time_us / r.timer_resolution_us) * r.timer_resolution_us;
  if (width_us < r.min_pulse_us)
    Refuse("at " + Fmt(p.rpm, 0) + " rpm the tool turns one " + Fmt(r.resolution_deg, 3) +
           " deg step in " + Fmt(p.step_time_us, 3) + " us, shorter than the illuminator's " +
           Fmt(r.min_pulse_us, 3) + " us pulse: lower the speed or coarsen the resolution");
  if (window_us < width_us)
    width_us = std::floor(window_us / r.timer_resolution_us) * r.timer_resolution_us;
  return width_us;
}

// Image i's position, and (synchronised) its first pulse's start in the frame [us]: where the
// tool is at the position, the first time after the window opens.
void PulseSchedule(
    const StrobeRequest& r, double frame_us, double rev_us, bool any_angle, StrobePlan* p) {
  const int n = p->positions;
  for (int i = 0; i < n; ++i) {
    const int pos = static_cast<int>((static_cast<long long>(i) * p->skip) % n);
    p->position.push_back(pos);
    if (!r.synchronised) continue;
    // The pulse's centre where the tool is at `pos`: from the window's start, the first time
    // the angle (revolutions since the first frame began) reaches pos / n.
    const double window_start_us = i * frame_us + r.blanking_us;
    const double wait_rev =
        any_angle ? Frac(static_cast<double>(pos) / n - Frac(window_start_us / rev_us)) : 0.0;
    double start = std::round((r.blanking_us + wait_rev * rev_us - p->pulse_width_us / 2) /
                              r.timer_resolution_us) *
                   r.timer_resolution_us;
    // Too early for the window: the same angle comes round one revolution later.
    if (start < r.blanking_us) start += any_angle ? rev_us : r.blanking_us - start;
    p->first_pulse_us.push_back(start);
  }
}

std::string PlanNote(const StrobeRequest& r, const StrobePlan& p) {
  std::ostringstream note;
  if (p.rpm_changed)
    note << "run the spindle at " << Fmt(p.rpm, 2) << " rpm (asked " << Fmt(r.rpm, 2)
         << "): each image then advances " << p.skip << " of " << p.positions << " positions. ";
  if (!r.synchronised)
    note << "free-running: one pulse per frame at the frame rate; a pulse that drifts into a "
            "frame change loses that image (repeat the positions missed). ";
  return note.str();
}

}  // namespace

StrobePlan PlanStrobe(const StrobeRequest& r) {
  Check(r);
  StrobePlan p;
  p.positions = PositionCount(r);
  const int n = p.positions;
  double rps = r.rpm / 60.0;
  const double frame_us = 1e6 / r.frame_rate_hz;
  const double window_us = frame_us - 2 * r.blanking_us;  // where pulses may fire
  p.duration_s = n / r.frame_rate_hz;
  if (p.duration_s > r.max_duration_s)
    Refuse("covering " + std::to_string(n) + " positions at " + Fmt(r.frame_rate_hz, 1) +
           " images per second takes " + Fmt(p.duration_s, 1) + " s, over the limit of " +
           Fmt(r.max_duration_s, 1) + " s");
  if (window_us < r.min_pulse_us)
    Refuse("a frame of " + Fmt(frame_us, 1) + " us leaves no room for a pulse beside its " +
           Fmt(r.blanking_us, 1) + " us blanking at either end");
  // Every angle can be reached in every frame when a whole revolution fits in the window.
  const bool any_angle = r.synchronised && 1e6 / rps + r.min_pulse_us <= window_us;
  if (!any_angle) p.skip = CoveringStep(r, n, &rps);
  p.rpm = rps * 60, p.rpm_changed = std::abs(p.rpm - r.rpm) > 1e-9 * r.rpm;
  const double rev_us = 1e6 / rps;
  p.step_time_us = rev_us / n;
  p.pulse_width_us = PulseWidthUs(r, p, window_us);
  // Pulses one revolution apart freeze the same angle: as many as fit after any start.
  p.pulses_per_image =
      any_angle
          ? std::min(
                r.max_pulses_per_image,
                1 + static_cast<int>(std::floor((window_us - p.pulse_width_us - rev_us) / rev_us)))
          : 1;
  p.pulse_spacing_us = p.pulses_per_image > 1 ? rev_us : 0.0;
  p.pulse_rate_hz = p.pulses_per_image * r.frame_rate_hz;
  p.worst_angle_error_deg = 0.5 * r.timer_resolution_us * 1e-6 * rps * 360.0;
  PulseSchedule(r, frame_us, rev_us, any_angle, &p);
  p.note = PlanNote(r, p);
  return p;
}

}  // namespace mlp::toolcam
