#include "mlp/probe_fw/ghost.h"

#include "mlp/probe_fw/triangulate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <tuple>

namespace mlp::probe_fw {
namespace {

// One row's observations linked through the sweep: indices into the observations, frame order.
using Trace = std::vector<std::size_t>;

// Where trace `t` should be in `frame`: its last centre moved on at its last step's speed (a
// stripe on one surface moves smoothly through the sweep; a reflection moves differently).
// A trace of one member moves at the row's typical speed.
double Predicted(const std::vector<SweepObservation>& obs,
                 const Trace& t,
                 int frame,
                 double row_px_per_frame) {
  const SweepObservation& last = obs[t.back()];
  if (t.size() < 2) return last.stripe.Along() + row_px_per_frame * (frame - last.frame);
  const SweepObservation& before = obs[t[t.size() - 2]];
  const double px_per_frame = (last.stripe.Along() - before.stripe.Along()) /
                              static_cast<double>(last.frame - before.frame);
  return last.stripe.Along() + px_per_frame * (frame - last.frame);
}

// Links the observations of one frame to the traces whose last member is at most
// `max_gap_frames` before (frames may lose the stripe: speckle, a ghost beside it): the closest
// pairs first, each trace and observation once (a reflection near the stripe must not steal its
// trace). Close means within the gate of a trace's last centre while it has one member, within
// `track_px` of its motion's prediction after that. The rest start traces.
void LinkFrame(const std::vector<SweepObservation>& obs,
               const std::vector<std::size_t>& frame_members,
               const GhostOptions& o,
               double row_px_per_frame,
               std::vector<Trace>* traces) {
  struct Pair {
    double px;
    std::size_t member, trace;
  };
  std::vector<Pair> pairs;
  for (std::size_t m : frame_members) {
    for (std::size_t t = 0; t < traces->size(); ++t) {
      const Trace& trace = (*traces)[t];
      const int gap = obs[m].frame - obs[trace.back()].frame;
      if (gap < 1 || gap > o.max_gap_frames) continue;
      const double px =
          std::abs(obs[m].stripe.Along() - Predicted(obs, trace, obs[m].frame, row_px_per_frame));
      if (px <= (trace.size() < 2 ? o.link_gate_px : o.track_px * std::sqrt(gap)))
        pairs.push_back({px, m, t});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) { return a.px < b.px; });
  std::vector<bool> trace_taken(traces->size(), false);
  std::vector<std::size_t> linked;
  for (const Pair& p : pairs) {
    if (trace_taken[p.trace] || std::find(linked.begin(), linked.end(), p.member) != linked.end())
      continue;
    trace_taken[p.trace] = true;
    linked.push_back(p.member);
    (*traces)[p.trace].push_back(p.member);
  }
  for (std::size_t m : frame_members) {
    if (std::find(linked.begin(), linked.end(), m) == linked.end()) traces->push_back({m});
  }
}

// How far the stripe moves on this row from one frame to the next [px], as most of its centres
// say: the median over each centre's nearest centre in the next frame (within the gate). The
// direct stripe is the brighter and usually the more often found, so it sets the median.
double RowSpeed(const std::vector<SweepObservation>& obs,
                const std::vector<std::size_t>& row,
                double gate_px) {
  std::vector<double> steps;
  for (std::size_t a = 0; a < row.size(); ++a) {
    double best = gate_px + 1.0, step = 0.0;
    for (std::size_t b = a + 1; b < row.size() && obs[row[b]].frame <= obs[row[a]].frame + 1; ++b) {
      if (obs[row[b]].frame != obs[row[a]].frame + 1) continue;
      const double d = obs[row[b]].stripe.Along() - obs[row[a]].stripe.Along();
      if (std::abs(d) < best) best = std::abs(d), step = d;
    }
    if (best <= gate_px) steps.push_back(step);
  }
  if (steps.empty()) return 0.0;
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2),
                   steps.end());
  return steps[steps.size() / 2];
}

// One row's traces; `row` is sorted by frame.
std::vector<Trace> LinkRow(const std::vector<SweepObservation>& obs,
                           const std::vector<std::size_t>& row,
                           const GhostOptions& o) {
  const double speed = RowSpeed(obs, row, o.link_gate_px);
  std::vector<Trace> traces;
  for (std::size_t begin = 0; begin < row.size();) {
    std::size_t end = begin;
    while (end < row.size() && obs[row[end]].frame == obs[row[begin]].frame) ++end;
    LinkFrame(obs,
              {row.begin() + static_cast<std::ptrdiff_t>(begin),
               row.begin() + static_cast<std::ptrdiff_t>(end)},
              o, speed, &traces);
    begin = end;
  }
  return traces;
}

// Members of `b` on pixels that `a` crossed at a column more than `columns` away (the column at
// which `a` crossed a pixel is interpolated between its members on either side, and extrapolated
// by one step beyond its ends: the AOI's edge may end a trace a pixel short of a reflection).
std::size_t Conflicts(const std::vector<SweepObservation>& obs,
                      const Trace& a,
                      const Trace& b,
                      double columns) {
  std::size_t n = 0;
  for (std::size_t j : b) {
    const double x = obs[j].stripe.Along();
    for (std::size_t k = 0; k + 1 < a.size(); ++k) {
      const SweepObservation &p = obs[a[k]], &q = obs[a[k + 1]];
      const double step = q.stripe.Along() - p.stripe.Along();
      // The segment, widened by its own length at the trace's first and last members.
      const double t_lo = k == 0 ? -1.0 : 0.0, t_hi = k + 2 == a.size() ? 2.0 : 1.0;
      const double t = step != 0.0 ? (x - p.stripe.Along()) / step : 0.5;
      if (step == 0.0 ? x != p.stripe.Along() : (t < t_lo || t > t_hi)) continue;
      if (std::abs(obs[j].column - (p.column + t * (q.column - p.column))) > columns) {
        ++n;
        break;
      }
    }
  }
  return n;
}

double MedianAmplitude(const std::vector<SweepObservation>& obs, const Trace& t) {
  std::vector<double> a;
  for (std::size_t i : t) a.push_back(obs[i].stripe.amplitude_dn);
  std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(a.size() / 2), a.end());
  return a[a.size() / 2];
}

// How a trace moved through the sweep: +1 or -1 along its scan line as the column grew, times
// the way direct light moves there (so +1: the direct way, -1: against it), 0 when it moved too
// little to tell or the way is unknown.
int Way(const std::vector<SweepObservation>& obs, const Trace& t, const GhostOptions& o) {
  const SweepObservation &first = obs[t.front()], &last = obs[t.back()];
  const double expected =
      first.stripe.axis == ScanAxis::kRow ? o.row_motion_sign : o.column_motion_sign;
  const double moved = last.stripe.Along() - first.stripe.Along();
  const double columns = last.column - first.column;
  if (expected == 0.0 || t.size() < 2 || std::abs(moved) < o.min_motion_px || columns == 0.0)
    return 0;
  return moved * columns * expected > 0.0 ? 1 : -1;
}

// Which of two conflicting traces is indirect light: one that moves the direct way beats one
// that has no direction; else the clearly weaker one; else a blip against a trace several times
// longer (noise above the threshold, not a reflection); else both, since neither can be told
// apart.
void Resolve(const std::vector<SweepObservation>& obs,
             const std::vector<Trace>& traces,
             std::size_t i,
             std::size_t j,
             const GhostOptions& o,
             std::vector<bool>* lost) {
  constexpr std::size_t kLonger = 3;
  const int wi = Way(obs, traces[i], o), wj = Way(obs, traces[j], o);
  if (wi != wj && (wi > 0 || wj > 0)) {
    (*lost)[wi > 0 ? j : i] = true;
    return;
  }
  const double si = MedianAmplitude(obs, traces[i]), sj = MedianAmplitude(obs, traces[j]);
  const std::size_t ni = traces[i].size(), nj = traces[j].size();
  if (si >= o.dominance * sj || ni >= kLonger * nj) {
    (*lost)[j] = true;
  } else if (sj >= o.dominance * si || nj >= kLonger * ni) {
    (*lost)[i] = true;
  } else {
    (*lost)[i] = (*lost)[j] = true;
  }
}

// One row: marks the members of traces that lose a conflict; returns how many it marked.
std::size_t RejectInRow(std::vector<SweepObservation>* observations,
                        const std::vector<std::size_t>& row,
                        const GhostOptions& o) {
  std::vector<SweepObservation>& obs = *observations;
  const std::vector<Trace> traces = LinkRow(obs, row, o);
  std::vector<bool> lost(traces.size(), false);
  for (std::size_t t = 0; t < traces.size(); ++t) lost[t] = Way(obs, traces[t], o) < 0;
  for (std::size_t i = 0; i < traces.size(); ++i) {
    for (std::size_t j = i + 1; j < traces.size(); ++j) {
      if (Conflicts(obs, traces[i], traces[j], o.same_ray_columns) +
              Conflicts(obs, traces[j], traces[i], o.same_ray_columns) >
          0) {
        Resolve(obs, traces, i, j, o, &lost);
      }
    }
  }
  std::size_t marked = 0;
  for (std::size_t t = 0; t < traces.size(); ++t) {
    if (!lost[t]) continue;
    for (std::size_t i : traces[t]) obs[i].indirect = true;
    marked += traces[t].size();
  }
  return marked;
}

}  // namespace

void DirectMotion(const ProbeModel& model, double* row_sign, double* column_sign) {
  const ProjectorModel& p = model.projector;
  *row_sign = *column_sign = 0.0;
  // The central column's sheet first; where it runs parallel to the optical axis (a projector
  // whose middle column points straight ahead beside the camera: the outside renderers' probes
  // had no direction at all), the nearest column whose sheet meets the axis in front.
  for (int k = 0; k <= 16; ++k) {
    // c_px, then c_px -+ 1/32 of the columns, -+ 2/32, ...
    const int offset = (k + 1) / 2;
    const double column = p.c_px + (k % 2 == 0 ? offset : -offset) * (p.columns / 32.0);
    Vec3 n0, n1;
    double d0 = 0.0, d1 = 0.0;
    p.PlaneOf(column, &n0, &d0);
    p.PlaneOf(column + 1.0, &n1, &d1);
    if (!(std::abs(n0.z()) > 1e-9)) continue;  // the optical axis lies in the sheet
    const Vec3 p0(0.0, 0.0, d0 / n0.z());      // the sheet on the optical axis
    // The next sheet at the same depth: p0 moved within z = p0.z along that sheet's normal.
    const Vec3 across(n1.x(), n1.y(), 0.0);
    if (!(p0.z() > 0.0) || !(across.squaredNorm() > 1e-18)) continue;
    const Vec3 p1 = p0 + (d1 - n1.dot(p0)) / n1.dot(across) * across;
    const Vec2 step = model.camera.Project(p1) - model.camera.Project(p0);
    const double whole = step.norm();
    if (!(whole > 0.0)) continue;
    if (std::abs(step.x()) > 0.1 * whole) *row_sign = step.x() > 0.0 ? 1.0 : -1.0;
    if (std::abs(step.y()) > 0.1 * whole) *column_sign = step.y() > 0.0 ? 1.0 : -1.0;
    return;
  }
}

std::size_t RejectIndirectLight(std::vector<SweepObservation>* observations,
                                const GhostOptions& options) {
  const std::vector<SweepObservation>& obs = *observations;
  std::vector<std::size_t> order(obs.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  // One scan line (a sensor row of the row scan, a column of the column scan) at a time.
  const auto same_line = [&](std::size_t a, std::size_t b) {
    return obs[a].stripe.axis == obs[b].stripe.axis && obs[a].stripe.Line() == obs[b].stripe.Line();
  };
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (obs[a].stripe.axis != obs[b].stripe.axis) return obs[a].stripe.axis < obs[b].stripe.axis;
    if (obs[a].stripe.Line() != obs[b].stripe.Line())
      return obs[a].stripe.Line() < obs[b].stripe.Line();
    if (obs[a].frame != obs[b].frame) return obs[a].frame < obs[b].frame;
    return obs[a].stripe.Along() < obs[b].stripe.Along();
  });
  std::size_t marked = 0;
  for (std::size_t begin = 0; begin < order.size();) {
    std::size_t end = begin;
    while (end < order.size() && same_line(order[end], order[begin])) ++end;
    const std::vector<std::size_t> row(order.begin() + static_cast<std::ptrdiff_t>(begin),
                                       order.begin() + static_cast<std::ptrdiff_t>(end));
    marked += RejectInRow(observations, row, options);
    begin = end;
  }
  return marked;
}

std::size_t RejectRayConflicts(const ProbeModel& model,
                               const RayOptions& options,
                               std::vector<SweepObservation>* seen) {
  struct OnRay {
    int axis, line, pixel;
    double depth_mm, tolerance_mm;
    std::size_t index;
  };
  std::vector<OnRay> rays;
  for (std::size_t i = 0; i < seen->size(); ++i) {
    const SweepObservation& o = (*seen)[i];
    if (o.indirect) continue;
    const StripePoint& s = o.stripe;
    const std::optional<Vec3> here = Triangulate(model, s.x_px, s.y_px, o.column);
    const bool row = s.axis == ScanAxis::kRow;
    const std::optional<Vec3> next =
        Triangulate(model, s.x_px + (row ? 1.0 : 0.0), s.y_px + (row ? 0.0 : 1.0), o.column);
    if (!here || !next) continue;
    const double per_pixel_mm = std::abs(next->z() - here->z());
    rays.push_back({static_cast<int>(s.axis), s.Line(), static_cast<int>(std::lround(s.Along())),
                    here->z(), std::max(options.min_depth_mm, options.pixels * per_pixel_mm), i});
  }
  std::sort(rays.begin(), rays.end(), [](const OnRay& a, const OnRay& b) {
    return std::tie(a.axis, a.line, a.pixel) < std::tie(b.axis, b.line, b.pixel);
  });
  std::size_t marked = 0;
  for (std::size_t b = 0; b < rays.size();) {
    std::size_t e = b + 1;
    while (e < rays.size() && rays[e].axis == rays[b].axis && rays[e].line == rays[b].line &&
           rays[e].pixel == rays[b].pixel)
      ++e;
    double lo = rays[b].depth_mm, hi = lo, tolerance = 0.0;
    for (std::size_t k = b; k < e; ++k) {
      lo = std::min(lo, rays[k].depth_mm), hi = std::max(hi, rays[k].depth_mm);
      tolerance = std::max(tolerance, rays[k].tolerance_mm);
    }
    if (hi - lo > tolerance) {
      for (std::size_t k = b; k < e; ++k) (*seen)[rays[k].index].indirect = true;
      marked += e - b;
    }
    b = e;
  }
  return marked;
}

namespace {

// The observations not yet marked, by scan line: (axis, line) -> indices.
std::map<std::pair<int, int>, std::vector<std::size_t>> DirectByLine(
    const std::vector<SweepObservation>& seen) {
  std::map<std::pair<int, int>, std::vector<std::size_t>> lines;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const SweepObservation& o = seen[i];
    if (!o.indirect) lines[{static_cast<int>(o.stripe.axis), o.stripe.Line()}].push_back(i);
  }
  return lines;
}

}  // namespace

namespace {

// For each member of `values` (in sequence order), the length of the longest sequence ending at
// it whose values never fall by more than `tolerance` from one member to the next (Fredman's
// patience sorting, O(n log n)).
std::vector<int> ChainLengths(const std::vector<double>& values, double tolerance) {
  std::vector<double> tails;  // the smallest last value of a sequence of each length
  std::vector<int> lengths(values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    const auto at = std::upper_bound(tails.begin(), tails.end(), values[k] + tolerance);
    lengths[k] = static_cast<int>(at - tails.begin()) + 1;
    if (at == tails.end()) {
      tails.push_back(values[k]);
    } else {
      *at = values[k];
    }
  }
  return lengths;
}

// The members of a longest ordered sequence that an ordered sequence only one member shorter
// leaves out: a line whose centres order almost as well another way does not say which of them
// is direct, so neither way's own members are kept. A reflection trailing the stripe through the
// sweep takes over where the stripe leaves the image, in order behind the stripe's last frames;
// its three frames made a longer sequence than the stripe's last two and the reflection was
// kept, 7-40 mm off (corpus 5050 scenes 162, 179: in 179 a reflection in frames 0-1 and the
// stripe from frame 2 on, the stripe's one frame the shorter way). One member the other way
// counts: two frames against one is no verdict by order alone, whichever two are direct (a
// stray one frame long behind the stripe's last two costs those two). The usual line, ordered
// one way only, has no such member. `values` in sequence order; `ending` and
// `starting_reversed` as ChainLengths gives them forwards and on the reversed negated values.
std::vector<bool> DoubtedByNearlyLongest(const std::vector<double>& values,
                                         const std::vector<int>& ending,
                                         const std::vector<int>& starting_reversed,
                                         const std::vector<bool>& on_longest,
                                         double tolerance_px) {
  const std::size_t n = values.size();
  const int longest = *std::max_element(ending.begin(), ending.end());
  const auto in_order = [&](std::size_t a, std::size_t b) {  // a before b in the sequence
    return a < b ? values[b] >= values[a] - tolerance_px : values[a] >= values[b] - tolerance_px;
  };
  std::vector<std::size_t> other_way;  // on a sequence one shorter, on no longest one
  for (std::size_t j = 0; j < n; ++j) {
    if (!on_longest[j] && ending[j] + starting_reversed[n - 1 - j] - 1 == longest - 1)
      other_way.push_back(j);
  }
  std::vector<bool> doubted(n, false);
  for (std::size_t j : other_way) {
    for (std::size_t k = 0; k < n; ++k) {
      if (on_longest[k] && !in_order(j, k)) doubted[k] = true;
    }
  }
  return doubted;
}

}  // namespace

std::size_t RejectOutOfOrder(double row_sign,
                             double column_sign,
                             double tolerance_px,
                             std::vector<SweepObservation>* seen) {
  auto lines = DirectByLine(*seen);
  std::size_t marked = 0;
  std::vector<double> forward, backward;
  for (auto& [key, members] : lines) {
    const double sign = key.first == static_cast<int>(ScanAxis::kRow) ? row_sign : column_sign;
    if (sign == 0.0 || members.size() < 2) continue;
    const auto value = [&](std::size_t i) { return sign * (*seen)[i].stripe.Along(); };
    std::sort(members.begin(), members.end(), [&](std::size_t a, std::size_t b) {
      return std::make_pair((*seen)[a].column, value(a)) <
             std::make_pair((*seen)[b].column, value(b));
    });
    // A member is kept only when every longest ordered sequence holds it: where two members
    // could take the same place (a reflection just behind the last direct centre: corpus 7474
    // scene 47), the sequence cannot tell which is direct, and keeping the later one kept the
    // reflection. Lengths of the sequences ending at each member and, run backwards on the
    // negated values, starting at it; on some longest sequence when they add up to its length,
    // on every one when no other such member stands at the same place.
    const std::size_t n = members.size();
    forward.resize(n), backward.resize(n);
    for (std::size_t k = 0; k < n; ++k) {
      forward[k] = value(members[k]);
      backward[k] = -value(members[n - 1 - k]);
    }
    const std::vector<int> ending = ChainLengths(forward, tolerance_px);
    const std::vector<int> starting_reversed = ChainLengths(backward, tolerance_px);
    const int longest = *std::max_element(ending.begin(), ending.end());
    std::vector<int> at_place(static_cast<std::size_t>(longest) + 1, 0);
    std::vector<bool> on_longest(n);
    for (std::size_t k = 0; k < n; ++k) {
      on_longest[k] = ending[k] + starting_reversed[n - 1 - k] - 1 == longest;
      if (on_longest[k]) ++at_place[static_cast<std::size_t>(ending[k])];
    }
    const std::vector<bool> doubted =
        DoubtedByNearlyLongest(forward, ending, starting_reversed, on_longest, tolerance_px);
    for (std::size_t k = 0; k < n; ++k) {
      const bool sure = on_longest[k] && at_place[static_cast<std::size_t>(ending[k])] == 1;
      if (sure && !doubted[k]) continue;
      SweepObservation& o = (*seen)[members[k]];
      (sure ? o.doubted : o.indirect) = true;
      ++marked;
    }
  }
  return marked;
}

namespace {

// The sweep's sheets in column order: rank of each observation's column among all of them.
class SheetRanks {
 public:
  SheetRanks(const std::vector<SweepObservation>& a, const std::vector<SweepObservation>& b) {
    for (const auto* v : {&a, &b})
      for (const SweepObservation& o : *v) columns_.push_back(o.column);
    std::sort(columns_.begin(), columns_.end());
    columns_.erase(std::unique(columns_.begin(), columns_.end()), columns_.end());
  }
  int operator()(const SweepObservation& o) const {
    return static_cast<int>(std::lower_bound(columns_.begin(), columns_.end(), o.column) -
                            columns_.begin());
  }

 private:
  std::vector<double> columns_;
};

}  // namespace

std::size_t RejectBackwardRuns(double row_sign,
                               double column_sign,
                               double tolerance_px,
                               int min_steps,
                               int max_sheet_gap,
                               std::vector<SweepObservation>* seen) {
  // The sweep's sheets in column order (frames may sweep either way, or out of order).
  const SheetRanks sheet(*seen, {});
  auto lines = DirectByLine(*seen);
  std::vector<std::size_t> marked;
  for (auto& [key, members] : lines) {
    const double sign = key.first == static_cast<int>(ScanAxis::kRow) ? row_sign : column_sign;
    if (sign == 0.0 || members.size() < 2) continue;
    std::sort(members.begin(), members.end(),
              [&](std::size_t a, std::size_t b) { return (*seen)[a].column < (*seen)[b].column; });
    std::size_t run_from = 0;  // the first member of the current run of back-steps
    for (std::size_t k = 1; k <= members.size(); ++k) {
      bool back = false;
      if (k < members.size()) {
        const SweepObservation &a = (*seen)[members[k - 1]], &b = (*seen)[members[k]];
        back = sheet(b) - sheet(a) <= max_sheet_gap &&
               sign * (b.stripe.Along() - a.stripe.Along()) < -tolerance_px;
      }
      if (back) continue;
      if (k - 1 - run_from >= static_cast<std::size_t>(min_steps))
        for (std::size_t j = run_from; j < k; ++j) marked.push_back(members[j]);
      run_from = k;
    }
  }
  for (std::size_t i : marked) (*seen)[i].indirect = true;
  return marked.size();
}

std::size_t RejectOffRate(double row_sign,
                          double column_sign,
                          const RateOptions& options,
                          std::vector<SweepObservation>* seen) {
  const SheetRanks sheet(*seen, {});
  auto lines = DirectByLine(*seen);
  std::vector<std::size_t> marked;
  for (auto& line : lines) {
    std::vector<std::size_t>& members = line.second;
    const double sign =
        line.first.first == static_cast<int>(ScanAxis::kRow) ? row_sign : column_sign;
    if (sign == 0.0 || members.size() < 3) continue;
    std::sort(members.begin(), members.end(),
              [&](std::size_t a, std::size_t b) { return (*seen)[a].column < (*seen)[b].column; });
    // The end, the member nearest it and the next two inwards, at either end of the line.
    const long n = static_cast<long>(members.size());
    const auto at = [&](long k) -> const SweepObservation& {
      return (*seen)[members[static_cast<std::size_t>(k)]];
    };
    for (const auto& [end, inward] :
         {std::pair<long, long>{0, 1}, std::pair<long, long>{n - 1, -1}}) {
      const SweepObservation &e = at(end), &a = at(end + inward), &b = at(end + 2 * inward);
      if (std::abs(sheet(e) - sheet(a)) < options.min_gap_sheets || a.column == b.column) continue;
      const double rate = (a.stripe.Along() - b.stripe.Along()) / (a.column - b.column);
      const double step = rate * (e.column - a.column);
      const double off = e.stripe.Along() - (a.stripe.Along() + step);
      // Where the rate itself changes (a sphere towards its limb), by as much again over the gap.
      double bend = 0.0;
      if (n >= 4) {
        const SweepObservation& c = at(end + 3 * inward);
        if (b.column != c.column)
          bend = std::abs(rate - (b.stripe.Along() - c.stripe.Along()) / (b.column - c.column)) *
                 std::abs(e.column - a.column);
      }
      if (std::abs(off) > options.share * std::abs(step) + options.tolerance_px + bend)
        marked.push_back(members[static_cast<std::size_t>(end)]);
    }
  }
  for (std::size_t i : marked) (*seen)[i].indirect = true;
  return marked.size();
}

namespace {

// What one line's pixels were swept by: per pixel the earliest sheet a stretch over it ended at
// and the latest sheet one began at (a pixel nobody swept keeps INT_MAX / INT_MIN).
struct SweptLine {
  std::vector<int> earliest_end, latest_begin;
  void Reset(std::size_t pixels) {
    earliest_end.assign(pixels, std::numeric_limits<int>::max());
    latest_begin.assign(pixels, std::numeric_limits<int>::min());
  }
  void Sweep(double from_px, double to_px, int begin_sheet, int end_sheet) {
    const auto n = static_cast<long>(earliest_end.size());
    const long first = std::max(0L, static_cast<long>(std::ceil(from_px)));
    const long last = std::min(n - 1, static_cast<long>(std::floor(to_px)));
    for (long x = first; x <= last; ++x) {
      const auto i = static_cast<std::size_t>(x);
      earliest_end[i] = std::min(earliest_end[i], end_sheet);
      latest_begin[i] = std::max(latest_begin[i], begin_sheet);
    }
  }
};

}  // namespace

std::size_t RejectSweptTwice(double row_sign,
                             double column_sign,
                             const std::vector<SweepObservation>& evidence,
                             const SweptOptions& o,
                             std::vector<SweepObservation>* seen) {
  const SheetRanks sheet(*seen, evidence);
  struct Claim {
    int sheet;
    double along;
  };
  std::map<std::pair<int, int>, std::vector<Claim>> claims;  // (axis, line) -> who swept it
  const auto add = [&](const SweepObservation& s) {
    claims[{static_cast<int>(s.stripe.axis), s.stripe.Line()}].push_back(
        {sheet(s), s.stripe.Along()});
  };
  for (const SweepObservation& s : *seen)
    if (!s.indirect) add(s);
  for (const SweepObservation& s : evidence) add(s);
  std::size_t marked = 0;
  SweptLine swept;
  for (auto& [key, members] : DirectByLine(*seen)) {
    const double sign = key.first == static_cast<int>(ScanAxis::kRow) ? row_sign : column_sign;
    if (sign == 0.0) continue;
    std::vector<Claim>& by = claims[key];
    std::sort(by.begin(), by.end(),
              [](const Claim& a, const Claim& b) { return a.sheet < b.sheet; });
    double longest = 0.0;
    for (const Claim& c : by) longest = std::max(longest, c.along);
    swept.Reset(static_cast<std::size_t>(longest) + 2);
    for (std::size_t a = 0; a < by.size(); ++a) {
      for (std::size_t b = a + 1; b < by.size() && by[b].sheet - by[a].sheet <= o.max_sheet_gap;
           ++b) {
        if (by[b].sheet == by[a].sheet || std::abs(by[b].along - by[a].along) > o.max_step_px)
          continue;
        const auto [lo, hi] = std::minmax(by[a].along, by[b].along);
        swept.Sweep(lo + o.margin_px, hi - o.margin_px, by[a].sheet, by[b].sheet);
      }
    }
    for (std::size_t i : members) {
      SweepObservation& s = (*seen)[i];
      const long at = std::lround(s.stripe.Along());
      if (at < 0 || at >= static_cast<long>(swept.earliest_end.size())) continue;
      const auto px = static_cast<std::size_t>(at);
      const int own = sheet(s);
      if (swept.earliest_end[px] >= own - o.max_sheet_gap &&
          swept.latest_begin[px] <= own + o.max_sheet_gap)
        continue;
      s.indirect = true;
      ++marked;
    }
  }
  return marked;
}

std::size_t RejectBehindClippedLight(double row_sign,
                                     double column_sign,
                                     const std::vector<SweepObservation>& evidence,
                                     double tolerance_px,
                                     std::vector<SweepObservation>* seen) {
  const SheetRanks sheet(*seen, evidence);
  // (axis, line) -> the clipped stripes on it: (sheet, signed position along the line).
  std::map<std::pair<int, int>, std::vector<std::pair<int, double>>> clipped;
  for (const SweepObservation& e : evidence) {
    if (!e.stripe.full_scale) continue;
    const double sign = e.stripe.axis == ScanAxis::kRow ? row_sign : column_sign;
    if (sign != 0.0)
      clipped[{static_cast<int>(e.stripe.axis), e.stripe.Line()}].emplace_back(
          sheet(e), sign * e.stripe.Along());
  }
  std::size_t marked = 0;
  for (auto& [key, members] : DirectByLine(*seen)) {
    const auto it = clipped.find(key);
    if (it == clipped.end()) continue;
    const double sign = key.first == static_cast<int>(ScanAxis::kRow) ? row_sign : column_sign;
    for (std::size_t i : members) {
      SweepObservation& s = (*seen)[i];
      const int own = sheet(s);
      const double at = sign * s.stripe.Along();
      const bool out_of_order =
          std::any_of(it->second.begin(), it->second.end(), [&](const auto& c) {
            return (c.first < own && c.second > at + tolerance_px) ||
                   (c.first > own && c.second < at - tolerance_px);
          });
      if (!out_of_order) continue;
      s.indirect = true;
      ++marked;
    }
  }
  return marked;
}

namespace {

std::size_t Root(std::vector<std::size_t>* parent, std::size_t i) {
  while ((*parent)[i] != i) i = (*parent)[i] = (*parent)[(*parent)[i]];
  return i;
}

}  // namespace

std::size_t SpreadAlongStripes(double link_gate_px,
                               int max_line_gap,
                               double share,
                               std::vector<SweepObservation>* seen) {
  // (frame, axis) -> observations by line; linked into stripes by union-find.
  std::map<std::pair<int, int>, std::vector<std::size_t>> frames;
  for (std::size_t i = 0; i < seen->size(); ++i)
    frames[{(*seen)[i].frame, static_cast<int>((*seen)[i].stripe.axis)}].push_back(i);
  std::vector<std::size_t> parent(seen->size());
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  for (auto& [key, members] : frames) {
    const auto line = [&](std::size_t i) { return (*seen)[i].stripe.Line(); };
    std::sort(members.begin(), members.end(),
              [&](std::size_t a, std::size_t b) { return line(a) < line(b); });
    for (std::size_t a = 0; a < members.size(); ++a) {
      for (std::size_t b = a + 1; b < members.size(); ++b) {
        if (line(members[b]) - line(members[a]) > max_line_gap) break;
        if (line(members[b]) == line(members[a])) continue;
        const double apart =
            std::abs((*seen)[members[b]].stripe.Along() - (*seen)[members[a]].stripe.Along());
        if (apart <= link_gate_px) parent[Root(&parent, members[b])] = Root(&parent, members[a]);
      }
    }
  }
  // Per root: (marked, all). Indexed by the root itself: no map on the firmware's hot path.
  std::vector<std::pair<std::size_t, std::size_t>> stripes(seen->size());
  for (std::size_t i = 0; i < seen->size(); ++i) {
    auto& [marked, all] = stripes[Root(&parent, i)];
    marked += (*seen)[i].indirect, ++all;
  }
  std::size_t spread = 0;
  for (std::size_t i = 0; i < seen->size(); ++i) {
    const auto& [marked, all] = stripes[Root(&parent, i)];
    if ((*seen)[i].indirect || !(static_cast<double>(marked) > share * static_cast<double>(all)))
      continue;
    (*seen)[i].indirect = true;
    ++spread;
  }
  return spread;
}

namespace {

// Which epipolar line a pixel is on, and where along it, whichever scan found it (a cross
// scan's observation lies on the epipolar line through its pixel, at its own line's index).
double EpipolarLineOf(const StripePoint& s, ScanAxis epipolar) {
  return epipolar == ScanAxis::kRow ? s.y_px : s.x_px;
}

double AlongEpipolar(const StripePoint& s, ScanAxis epipolar) {
  return epipolar == ScanAxis::kRow ? s.x_px : s.y_px;
}

}  // namespace

std::size_t RejectAcrossOrder(double row_sign,
                              double column_sign,
                              double tolerance_px,
                              std::vector<SweepObservation>* seen) {
  if ((row_sign == 0.0) == (column_sign == 0.0)) return 0;
  const ScanAxis epipolar = row_sign != 0.0 ? ScanAxis::kRow : ScanAxis::kColumn;
  const double sign = row_sign != 0.0 ? row_sign : column_sign;
  // Each epipolar line's direct observations, as (column, signed position) sorted by column.
  std::map<int, std::vector<std::pair<double, double>>> lines;
  for (const SweepObservation& o : *seen) {
    if (o.indirect || o.stripe.axis != epipolar) continue;
    lines[o.stripe.Line()].emplace_back(o.column, sign * o.stripe.Along());
  }
  for (auto& [line, members] : lines) std::sort(members.begin(), members.end());
  std::size_t marked = 0;
  for (SweepObservation& o : *seen) {
    if (o.indirect || o.stripe.axis == epipolar) continue;
    const auto it = lines.find(static_cast<int>(std::lround(EpipolarLineOf(o.stripe, epipolar))));
    if (it == lines.end()) continue;
    const auto& members = it->second;
    const double at = sign * AlongEpipolar(o.stripe, epipolar);
    // Neighbours by column from other frames (the same frame's stripe may bend onto the line).
    const auto above = std::upper_bound(members.begin(), members.end(), o.column,
                                        [](double c, const auto& m) { return c < m.first; });
    const auto below = std::lower_bound(members.begin(), members.end(), o.column,
                                        [](const auto& m, double c) { return m.first < c; });
    const bool after_below =
        below == members.begin() || at >= std::prev(below)->second - tolerance_px;
    const bool before_above = above == members.end() || at <= above->second + tolerance_px;
    if (after_below && before_above) continue;
    o.indirect = true;
    ++marked;
  }
  return marked;
}

}  // namespace mlp::probe_fw
