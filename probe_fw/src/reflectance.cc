#include "mlp/probe_fw/reflectance.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <tuple>

namespace mlp::probe_fw {
namespace {

// Observations in scan-line order: axis, line, frame, then along the line.
bool LineOrder(const SweepObservation& a, const SweepObservation& b) {
  if (a.stripe.axis != b.stripe.axis) return a.stripe.axis < b.stripe.axis;
  if (a.stripe.Line() != b.stripe.Line()) return a.stripe.Line() < b.stripe.Line();
  if (a.frame != b.frame) return a.frame < b.frame;
  return a.stripe.Along() < b.stripe.Along();
}

bool SameLine(const SweepObservation& a, const SweepObservation& b) {
  return a.stripe.axis == b.stripe.axis && a.stripe.Line() == b.stripe.Line();
}

// The shift of each observation: its profile's second moment times the mean slope of the
// observations of its frame on the lines within +-smooth_lines of its own and within
// smooth_along_px along them. A face's reflectance varies over the surface, speckle from grain to
// grain: the mean keeps the one and averages the other. NaN: no slope known.
std::vector<double> SmoothedShift(const std::vector<SweepObservation>& obs,
                                  const std::vector<std::size_t>& order,
                                  const std::vector<double>& slope,
                                  const ReflectanceOptions& options) {
  // Where each (axis, line, frame) starts in `order`.
  std::map<std::tuple<int, int, int>, std::size_t> first;
  for (std::size_t at = 0; at < order.size(); ++at) {
    const SweepObservation& o = obs[order[at]];
    first.emplace(std::make_tuple(int(o.stripe.axis), o.stripe.Line(), o.frame), at);
  }
  std::vector<double> shift(obs.size(), NAN);
  for (std::size_t i = 0; i < obs.size(); ++i) {
    if (!std::isfinite(slope[i])) continue;
    const SweepObservation& o = obs[i];
    double sum = 0.0;
    int n = 0;
    for (int dl = -options.smooth_lines; dl <= options.smooth_lines; ++dl) {
      const auto it =
          first.find(std::make_tuple(int(o.stripe.axis), o.stripe.Line() + dl, o.frame));
      if (it == first.end()) continue;
      for (std::size_t at = it->second; at < order.size(); ++at) {
        const SweepObservation& n_obs = obs[order[at]];
        if (n_obs.stripe.Line() != o.stripe.Line() + dl || n_obs.frame != o.frame ||
            n_obs.stripe.axis != o.stripe.axis)
          break;
        if (std::isfinite(slope[order[at]]) &&
            std::abs(n_obs.stripe.Along() - o.stripe.Along()) <= options.smooth_along_px) {
          sum += slope[order[at]], ++n;
        }
      }
    }
    shift[i] = sum / n * o.stripe.variance_px2;
  }
  return shift;
}

}  // namespace

ReflectanceCounts CorrectReflectanceSlope(std::vector<SweepObservation>* observations,
                                          const ReflectanceOptions& options) {
  std::vector<SweepObservation>& obs = *observations;
  std::vector<std::size_t> order(obs.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return LineOrder(obs[a], obs[b]); });
  // The nearest direct observation on the same line in frame `frame`, within the gate.
  const auto neighbour = [&](std::size_t at, int frame) -> const SweepObservation* {
    const SweepObservation& o = obs[order[at]];
    const SweepObservation* best = nullptr;
    double best_px = options.neighbour_gate_px;
    for (int dir : {-1, 1}) {
      for (std::ptrdiff_t k = static_cast<std::ptrdiff_t>(at) + dir;
           k >= 0 && k < static_cast<std::ptrdiff_t>(order.size()); k += dir) {
        const SweepObservation& n = obs[order[static_cast<std::size_t>(k)]];
        if (!SameLine(n, o) || std::abs(n.frame - o.frame) > 1) break;
        const double px = std::abs(n.stripe.Along() - o.stripe.Along());
        if (n.frame == frame && !n.indirect && px <= best_px) best = &n, best_px = px;
      }
    }
    return best;
  };
  std::vector<double> slope(obs.size(), NAN);
  ReflectanceCounts counts;
  for (std::size_t at = 0; at < order.size(); ++at) {
    const SweepObservation& o = obs[order[at]];
    if (o.indirect || o.doubted || !(o.stripe.mass_dn > 0.0)) continue;
    const SweepObservation* before = neighbour(at, o.frame - 1);
    const SweepObservation* after = neighbour(at, o.frame + 1);
    if (!before && !after) continue;
    // Central difference of ln(light) when both neighbours are there, one-sided otherwise.
    const SweepObservation& a = before ? *before : o;
    const SweepObservation& b = after ? *after : o;
    const double along = b.stripe.Along() - a.stripe.Along();
    if (!(std::abs(along) > 0.5) || !(a.stripe.mass_dn > 0.0) || !(b.stripe.mass_dn > 0.0))
      continue;
    slope[order[at]] = std::log(b.stripe.mass_dn / a.stripe.mass_dn) / along;
  }
  const std::vector<double> shift = SmoothedShift(obs, order, slope, options);
  for (std::size_t i = 0; i < obs.size(); ++i) {
    if (!std::isfinite(shift[i])) continue;
    if (std::abs(shift[i]) > options.max_shift_px) {
      obs[i].indirect = true;
      ++counts.dropped;
      continue;
    }
    StripePoint& s = obs[i].stripe;
    (s.axis == ScanAxis::kRow ? s.x_px : s.y_px) -= shift[i];
    ++counts.corrected;
  }
  return counts;
}

}  // namespace mlp::probe_fw
