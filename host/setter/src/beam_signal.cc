#include "mlp/setter/beam_signal.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace mlp::setter {
namespace {

[[noreturn]] void Fail(const std::string& what) { throw SetterInputError("beam signal: " + what); }

}  // namespace

void BeamModel::Validate() const {
  if (!(sample_rate_hz >= 10000 && sample_rate_hz <= 1e6)) Fail("sample_rate_hz: 10 kHz..1 MHz");
  if (!(beam_radius_mm > 0.001 && beam_radius_mm < 5)) Fail("beam_radius_mm: 0.001..5");
  if (!(clear_v > 0) || !(noise_v >= 0) || !(rise >= 0 && rise < 0.2) ||
      !(ripple >= 0 && ripple < 0.2) || !(drops_per_s >= 0))
    Fail("clear_v > 0; noise, drops >= 0; rise and ripple under 20 %");
}

double ToolInBeam::LongestRadius() const {
  return tooth_radius_mm.empty()
             ? 0.0
             : *std::max_element(tooth_radius_mm.begin(), tooth_radius_mm.end());
}

double ToolInBeam::Reach(double t) const {
  if (rpm == 0) return LongestRadius();
  const double turn = start_turn_rad + rpm / 60.0 * 2 * M_PI * t;
  double reach = core_share * *std::min_element(tooth_radius_mm.begin(), tooth_radius_mm.end());
  for (int k = 0; k < Teeth(); ++k)
    reach = std::max(
        reach, tooth_radius_mm[static_cast<size_t>(k)] * std::cos(turn + 2 * M_PI * k / Teeth()));
  return reach;
}

double Transmission(const BeamModel& b, double e, double width_mm) {
  const double w = b.beam_radius_mm;
  double t = 0.5 * std::erfc(std::sqrt(2.0) * e / w);
  // A strip: the light beyond its trailing side passes again.
  if (width_mm > 0) t += 1.0 - 0.5 * std::erfc(std::sqrt(2.0) * (e - width_mm) / w);
  // The rise just before blocking, and a ripple whose fringes close up towards the beam (a
  // knife edge's Fresnel pattern, in shape only).
  t += b.rise * std::exp(-std::pow((e + 1.5 * w) / (0.6 * w), 2));
  if (e < -w)
    t += b.ripple * std::exp((e + w) / (3 * w)) * std::cos(2 * M_PI * std::pow((e + w) / w, 2));
  return t;
}

BeamSignal GenerateSignal(const BeamModel& beam,
                          const ToolInBeam& tool,
                          const Motion& motion,
                          unsigned seed) {
  beam.Validate();
  if (tool.Teeth() < 1 || tool.Teeth() > 16 || !(tool.LongestRadius() > 0))
    Fail("the tool needs 1..16 teeth with radii > 0");
  if (!(tool.rpm >= 0 && tool.rpm <= 60000)) Fail("rpm: 0..60000");
  if (!(tool.width_mm >= 0)) Fail("the tool's width must be >= 0 (0: a solid edge)");
  if (!(motion.feed_mm_min > 0 && motion.feed_mm_min <= 5000) || !(motion.gap_mm >= 0) ||
      !(motion.duration_s > 0 && motion.duration_s <= 60))
    Fail("feed 0..5000 mm/min, gap >= 0, duration 0..60 s");
  std::mt19937 rng(seed);
  BeamSignal s;
  s.sample_rate_hz = beam.sample_rate_hz;
  const double r_max = tool.LongestRadius(), dt = 1 / beam.sample_rate_hz;
  s.axis_at_edge_mm = -r_max;
  s.axis_start_mm = motion.entering ? -motion.gap_mm - r_max : motion.gap_mm - r_max;
  s.axis_feed_mm_per_sample = motion.Dir() * motion.FeedMmPerS() * dt;
  // Drops: each dims the beam by a bell of its depth over its duration.
  struct Drop {
    double t, half, depth;
  };
  std::vector<Drop> drops;
  std::uniform_real_distribution<double> unit(0, 1);
  if (beam.drops_per_s > 0) {
    std::exponential_distribution<double> gap(beam.drops_per_s);
    for (double t = gap(rng); t < motion.duration_s; t += gap(rng)) {
      drops.push_back({t, 0.00015 + 0.0008 * unit(rng), 0.2 + 0.7 * unit(rng)});
      s.drop_times_s.push_back(t);
    }
  }
  std::normal_distribution<double> noise(0, beam.noise_v);
  const auto n = static_cast<size_t>(motion.duration_s * beam.sample_rate_hz);
  s.volts.resize(n);
  size_t next_drop = 0;
  for (size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * dt;
    const double pass =
        Transmission(beam, s.AxisAt(static_cast<double>(i)) + tool.Reach(t), tool.width_mm);
    double v = beam.clear_v * (beam.reflective ? 1.0 - pass : pass);
    while (next_drop < drops.size() && drops[next_drop].t + 4 * drops[next_drop].half < t)
      ++next_drop;
    for (size_t k = next_drop; k < drops.size() && drops[k].t - 4 * drops[k].half < t; ++k)
      v *= 1 - drops[k].depth * std::exp(-std::pow((t - drops[k].t) / drops[k].half, 2));
    s.volts[i] = static_cast<float>(v + (beam.noise_v > 0 ? noise(rng) : 0.0));
  }
  return s;
}

}  // namespace mlp::setter
