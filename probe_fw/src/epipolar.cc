#include "mlp/probe_fw/epipolar.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <map>
#include <numeric>
#include <utility>

#include <Eigen/Dense>

namespace mlp::probe_fw {
namespace {

enum class Drop : std::uint8_t { kKept, kWeaker, kUndecided, kBesideRejected, kIsolated };

// A candidate of the frame: a point, or a stripe rejected for its shape (evidence, never kept).
struct Candidate {
  StripePoint stripe;
  double epipolar_px = 0.0;  // which epipolar line, in pixels of the camera's focal length
  double light = 0.0;        // its amplitude above the background [DN], at least 1
  bool rejected = false;     // rejected for its shape: evidence, never a point
  int trace = -1;
  Drop drop = Drop::kKept;
};

// The epipolar planes turn about the baseline: the angle of the plane through the candidate's
// ray, times the focal length, numbers the lines one pixel apart near the image's centre.
class EpipolarIndex {
 public:
  explicit EpipolarIndex(const ProbeModel& model) : model_(model) {
    const Vec3 t = model.projector.Center();
    along_ = t.norm() > 0.0 ? t.normalized() : Vec3::UnitX();
    // Any direction square to the baseline: the one nearest the optical axis.
    e1_ = (Vec3::UnitZ() - Vec3::UnitZ().dot(along_) * along_);
    if (e1_.norm() < 1e-9) e1_ = Vec3::UnitY() - Vec3::UnitY().dot(along_) * along_;
    e1_.normalize();
    e2_ = along_.cross(e1_);
  }
  double Of(const StripePoint& s) const {
    const Vec2 xy = model_.camera.Undistort(Vec2(s.x_px, s.y_px));
    const Vec3 normal = along_.cross(Vec3(xy.x(), xy.y(), 1.0));
    return std::atan2(normal.dot(e2_), normal.dot(e1_)) * model_.camera.fy_px;
  }

 private:
  const ProbeModel& model_;
  Vec3 along_, e1_, e2_;
};

// Links the candidates of one scan axis along the stripe: by line, each joins the trace whose
// slope puts it nearest (within the gate), else starts one. Returns the number of traces.
int LinkTraces(const EpipolarOptions& o, std::vector<Candidate*>& axis, int first_trace) {
  std::sort(axis.begin(), axis.end(), [](const Candidate* a, const Candidate* b) {
    return std::make_pair(a->stripe.Line(), a->stripe.Along()) <
           std::make_pair(b->stripe.Line(), b->stripe.Along());
  });
  struct Open {
    int id, line;
    double along, slope;
    int claimed_line, members;
  };
  std::vector<Open> open;
  int next = first_trace;
  for (Candidate* c : axis) {
    const int line = c->stripe.Line();
    std::erase_if(open, [&](const Open& t) { return line - t.line > o.max_line_gap + 1; });
    Open* best = nullptr;
    double best_miss = o.link_gate_px;
    for (Open& t : open) {
      if (t.line >= line || t.claimed_line == line) continue;
      const double miss = std::abs(c->stripe.Along() - (t.along + t.slope * (line - t.line)));
      if (miss <= best_miss) best_miss = miss, best = &t;
    }
    if (!best) {
      open.push_back({next, line, c->stripe.Along(), 0.0, line, 1});
      c->trace = next++;
      continue;
    }
    const double slope = (c->stripe.Along() - best->along) / (line - best->line);
    best->slope = best->members == 1 ? slope : 0.5 * (best->slope + slope);
    best->line = line, best->along = c->stripe.Along(), best->claimed_line = line;
    ++best->members;
    c->trace = best->id;
  }
  return next;
}

// The verdict on two traces over the lines where they conflict: +1 the first is direct, -1 the
// second, 0 neither can be told. log_ratios: ln(light first / light second), line by line.
int Judge(const std::vector<double>& log_ratios, const EpipolarOptions& o) {
  const double n = static_cast<double>(log_ratios.size());
  const double mean = std::accumulate(log_ratios.begin(), log_ratios.end(), 0.0) / n;
  if (static_cast<int>(log_ratios.size()) < o.min_paired_lines) {
    if (mean > std::log(o.few_lines_dominance)) return 1;
    return mean < -std::log(o.few_lines_dominance) ? -1 : 0;
  }
  double ss = 0.0;
  for (double d : log_ratios) ss += (d - mean) * (d - mean);
  const double sd = std::sqrt(ss / (n - 1.0));
  const double independent = std::max(1.0, n / o.lines_per_independent);
  const double needed =
      std::max(std::log(o.min_dominance), o.significance * sd / std::sqrt(independent));
  if (mean > needed) return 1;
  return mean < -needed ? -1 : 0;
}

struct PairEvidence {
  std::vector<double> log_ratios;        // ln(light of the lower id / light of the higher id)
  std::vector<std::pair<int, int>> who;  // the candidates, lower id's first
};

// Every pair of candidates of different traces on one epipolar line: the evidence per pair of
// traces, keyed (lower trace id, higher).
std::map<std::pair<int, int>, PairEvidence> Conflicts(const std::vector<Candidate>& all,
                                                      const EpipolarOptions& o) {
  std::vector<int> order(all.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    return all[static_cast<size_t>(a)].epipolar_px < all[static_cast<size_t>(b)].epipolar_px;
  });
  std::map<std::pair<int, int>, PairEvidence> evidence;
  for (size_t i = 0; i < order.size(); ++i) {
    const Candidate& a = all[static_cast<size_t>(order[i])];
    for (size_t j = i + 1; j < order.size(); ++j) {
      const Candidate& b = all[static_cast<size_t>(order[j])];
      if (b.epipolar_px - a.epipolar_px >= o.same_line_px) break;
      if (a.trace == b.trace) continue;
      const bool a_first = a.trace < b.trace;
      const Candidate& lo = a_first ? a : b;
      const Candidate& hi = a_first ? b : a;
      PairEvidence& e = evidence[{lo.trace, hi.trace}];
      e.log_ratios.push_back(std::log(lo.light / hi.light));
      e.who.push_back(a_first ? std::make_pair(order[i], order[j])
                              : std::make_pair(order[j], order[i]));
    }
  }
  return evidence;
}

// The value at d = 0 of the parabola fitted by least squares to samples a(d) from the moments
// m[e] = sum d^e and t[e] = sum a d^e; `fallback` when fewer than five samples or a singular
// system. A symmetric window's parabola is unbiased to third order (Savitzky and Golay, Anal.
// Chem. 36, 1964). (Tried for the centres along a trace too, 2026-12-07: it took a small
// sphere's bias from -7 to -2.6 um on corpus 7878 scene 59, but moved the virtual probe's
// recheck hand-eye by 3.3-5 um where the line moved it 1.3, and stopped a bore's fit; not used
// there.)
double QuadraticAtZero(const std::array<double, 5>& m,
                       const std::array<double, 3>& t,
                       double fallback) {
  if (m[0] < 5) return fallback;
  const Eigen::Matrix3d normal{{m[0], m[1], m[2]}, {m[1], m[2], m[3]}, {m[2], m[3], m[4]}};
  const Eigen::Vector3d rhs(t[0], t[1], t[2]);
  const Eigen::LDLT<Eigen::Matrix3d> solve(normal);
  if (solve.info() != Eigen::Success || !(std::abs(solve.vectorD().minCoeff()) > 1e-9))
    return fallback;
  const double at_zero = solve.solve(rhs)(0);
  return std::isfinite(at_zero) ? at_zero : fallback;
}

// Adds one sample a at d to the moments QuadraticAtZero reads.
void AddMoments(int d, double a, std::array<double, 5>* m, std::array<double, 3>* t) {
  double p = 1.0;
  for (size_t e = 0; e < 5; ++e, p *= d) {
    (*m)[e] += p;
    if (e < 3) (*t)[e] += a * p;
  }
}

// Replaces each kept centre of a trace by a line fitted along the trace over +-half lines.
std::uint64_t FitAlongTraces(std::vector<Candidate>& all, int half) {
  if (half <= 0) return 0;
  std::map<int, std::vector<Candidate*>> traces;
  for (Candidate& c : all) {
    if (!c.rejected && c.drop == Drop::kKept) traces[c.trace].push_back(&c);
  }
  std::uint64_t moved = 0;
  std::vector<double> fitted;
  for (auto& [id, members] : traces) {
    const size_t n = members.size();
    fitted.assign(n, 0.0);
    const int first = members.front()->stripe.Line(), last = members.back()->stripe.Line();
    for (size_t i = 0; i < n; ++i) {
      const int line = members[i]->stripe.Line();
      // A window as long on both sides: a one-sided one bends a curving stripe's centre.
      const int reach = std::min({half, line - first, last - line});
      double s0 = 0, s1 = 0, s2 = 0, t0 = 0, t1 = 0;
      for (size_t k = i - std::min(i, static_cast<size_t>(half)); k < n; ++k) {
        const int d = members[k]->stripe.Line() - line;
        if (d < -reach) continue;
        if (d > reach) break;
        const double a = members[k]->stripe.Along();
        s0 += 1, s1 += d, s2 += d * d, t0 += a, t1 += a * d;
      }
      const double det = s0 * s2 - s1 * s1;
      // Three centres at least: the fit at d = 0.
      fitted[i] = (s0 >= 3 && det > 0) ? (t0 * s2 - t1 * s1) / det : members[i]->stripe.Along();
    }
    for (size_t i = 0; i < n; ++i) {
      StripePoint& s = members[i]->stripe;
      (s.axis == ScanAxis::kRow ? s.x_px : s.y_px) = fitted[i];
      ++moved;
    }
  }
  return moved;
}

// Marks `loser` dropped for losing against `winner` (or, winner null, for a draw), keeping the
// first reason a candidate was given.
void Mark(Candidate& loser, const Candidate* winner) {
  if (loser.drop != Drop::kKept) return;
  loser.drop =
      !winner ? Drop::kUndecided : (winner->rejected ? Drop::kBesideRejected : Drop::kWeaker);
}

// The candidates linked along the stripe: per trace, its members in line order.
std::map<int, std::vector<Candidate*>> Traces(std::vector<Candidate>& all,
                                              const EpipolarOptions& o) {
  int traces = 0;
  for (ScanAxis axis : {ScanAxis::kRow, ScanAxis::kColumn}) {
    std::vector<Candidate*> on_axis;
    for (Candidate& c : all) {
      if (c.stripe.axis == axis) on_axis.push_back(&c);
    }
    traces = LinkTraces(o, on_axis, traces);
  }
  std::map<int, std::vector<Candidate*>> by_trace;
  for (Candidate& c : all) by_trace[c.trace].push_back(&c);
  for (auto& [id, members] : by_trace) {
    std::sort(members.begin(), members.end(), [](const Candidate* a, const Candidate* b) {
      return a->stripe.Line() < b->stripe.Line();
    });
  }
  return by_trace;
}

// ln(light) of a trace's members on and within `reach` lines of [first, last] (its own lines).
std::vector<double> LogLightNear(const std::vector<Candidate*>& members,
                                 int first,
                                 int last,
                                 int reach) {
  std::vector<double> out;
  for (const Candidate* m : members) {
    const int line = m->stripe.Line();
    if (line >= first - reach && line <= last + reach) out.push_back(std::log(m->light));
  }
  return out;
}

// The verdict on two traces that share too few epipolar lines for the paired test: each one's
// light on and near the shared lines, an unpaired test with the paired test's margins (the same
// speckle shared by neighbouring lines). A stripe's and a reflection's pieces often meet on a
// line or two only (a curve turning along the epipolar lines); two lines' ratio cannot tell a
// speckle grain from a reflection, the light of the traces about them can. Returns +1 (first
// direct), -1 (second), 0; *whole: decided on enough light of both to judge the traces whole.
int JudgeFewLines(const PairEvidence& e,
                  const std::vector<Candidate>& all,
                  const std::map<int, std::vector<Candidate*>>& traces,
                  std::pair<int, int> ids,
                  const EpipolarOptions& o,
                  bool* whole) {
  std::array<std::vector<double>, 2> near;
  for (int side = 0; side < 2; ++side) {
    int first = std::numeric_limits<int>::max(), last = std::numeric_limits<int>::min();
    for (const auto& pair : e.who) {
      const int line = all[static_cast<size_t>(side == 0 ? pair.first : pair.second)].stripe.Line();
      first = std::min(first, line), last = std::max(last, line);
    }
    near[static_cast<size_t>(side)] =
        LogLightNear(traces.at(side == 0 ? ids.first : ids.second), first, last, o.few_lines_reach);
  }
  *whole = false;
  // Too little light near the shared lines: Judge's plain ratio of the shared lines.
  if (std::min(near[0].size(), near[1].size()) < static_cast<size_t>(o.min_paired_lines))
    return Judge(e.log_ratios, o);
  std::array<double, 2> mean{}, var_of_mean{};
  for (size_t side = 0; side < 2; ++side) {
    const std::vector<double>& x = near[side];
    const double n = static_cast<double>(x.size());
    mean[side] = std::accumulate(x.begin(), x.end(), 0.0) / n;
    double ss = 0.0;
    for (double v : x) ss += (v - mean[side]) * (v - mean[side]);
    var_of_mean[side] = ss / (n - 1.0) / std::max(1.0, n / o.lines_per_independent);
  }
  const double d = mean[0] - mean[1];
  const double needed = std::max(std::log(o.min_dominance),
                                 o.significance * std::sqrt(var_of_mean[0] + var_of_mean[1]));
  *whole = std::abs(d) > needed;
  if (d > needed) return 1;
  return d < -needed ? -1 : 0;
}

// The median of ln(light) over a whole trace (a saturated member counts its clipped peak: a
// bound from below).
double MedianLogLight(const std::vector<Candidate*>& members) {
  std::vector<double> v;
  v.reserve(members.size());
  for (const Candidate* m : members) v.push_back(std::log(m->light));
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// Whether the verdict of the shared lines is contradicted by the traces as wholes: the winner is
// the shorter trace and clearly the dimmer over its length. A reflection of the stripe's bright
// middle can land beside the stripe's dim end (a cylinder's limb: Lambert's cosine) and outshine
// it there; that local verdict made a whole stripe of 562 lines lose to a reflection of 30, kept
// 0.7-5 mm off (corpus 7979 scene 61, the probe turned, over-exposed). Where the two kinds of
// evidence disagree neither trace is believed: both go whole (the stripe's other lines too; a
// missing stripe is safe, and letting the longer one keep its lines would keep a long
// reflection's wherever a short stripe inside it is the one that wins locally).
bool ContradictedByWholeTraces(const std::vector<Candidate*>& winner,
                               const std::vector<Candidate*>& loser,
                               const EpipolarOptions& o) {
  if (winner.size() >= loser.size()) return false;
  return MedianLogLight(loser) - MedianLogLight(winner) > std::log(o.min_dominance);
}

// Marks the losers of every conflict: on the shared lines, the weaker trace's candidates (both
// traces' in a draw); a trace that lost over many lines is a reflection and goes whole.
void Decide(std::vector<Candidate>& all,
            const std::map<int, std::vector<Candidate*>>& traces,
            const EpipolarOptions& o) {
  std::map<int, const Candidate*> lost;  // trace -> a candidate of the trace it lost to
  for (const auto& [ids, e] : Conflicts(all, o)) {
    const bool paired = static_cast<int>(e.log_ratios.size()) >= o.min_paired_lines;
    bool whole = paired;
    const int verdict =
        paired ? Judge(e.log_ratios, o) : JudgeFewLines(e, all, traces, ids, o, &whole);
    const int winner = verdict > 0 ? ids.first : ids.second;
    const int loser = verdict > 0 ? ids.second : ids.first;
    if (verdict != 0 && ContradictedByWholeTraces(traces.at(winner), traces.at(loser), o)) {
      for (const auto& [lo, hi] : e.who) {
        Mark(all[static_cast<size_t>(lo)], nullptr);
        Mark(all[static_cast<size_t>(hi)], nullptr);
      }
      lost.emplace(winner, nullptr);
      lost.emplace(loser, nullptr);
      continue;
    }
    for (const auto& [lo, hi] : e.who) {
      Candidate& a = all[static_cast<size_t>(lo)];
      Candidate& b = all[static_cast<size_t>(hi)];
      if (verdict >= 0) Mark(b, verdict > 0 ? &a : nullptr);
      if (verdict <= 0) Mark(a, verdict < 0 ? &b : nullptr);
    }
    if (verdict == 0) {  // a draw: the shorter trace, more likely a reflection's piece, goes whole
      const size_t a = traces.at(ids.first).size(), b = traces.at(ids.second).size();
      if (a != b) lost.emplace(a < b ? ids.first : ids.second, nullptr);
      continue;
    }
    if (!whole) continue;
    const auto& [lo, hi] = e.who.front();
    if (verdict > 0) lost.emplace(ids.second, &all[static_cast<size_t>(lo)]);
    if (verdict < 0) lost.emplace(ids.first, &all[static_cast<size_t>(hi)]);
  }
  for (Candidate& c : all) {
    const auto it = lost.find(c.trace);
    if (it != lost.end()) Mark(c, it->second);
  }
}

// The light's trend along a trace is taken out over this many lines a side: a parabola's
// passband over 33 lines is about a mean's over 17, so grains of a few lines stay in the residual
// (over 17 lines the parabola took a quarter of the contrast of 4-line grains, and half their
// length).
constexpr int kSpeckleTrendLines = 16;
// Traces shorter than this are left out. Not the window's full 33: under heavy speckle the
// unsmoothed stripe breaks into pieces of a few dozen lines, and leaving them out left too few
// centres to see its speckle at all (outside renderer, plane, contrast 0.44).
constexpr std::size_t kSpeckleMinTraceLines = 17;

struct TraceLight {
  std::vector<int> lines;
  std::vector<double> relative;  // light / trend - 1
};

// Each member's light against its trend: a parabola fitted over the lines within
// kSpeckleTrendLines of its own. A parabola, not the mean: the light of a sphere's or a
// cylinder's stripe falls off towards the limb and bends over a few dozen lines (Lambert's
// cosine), and a running mean leaves that bend as a contrast of several per cent with a grain
// of lines, speckle that is not there (corpus 7878, scene 64: a noise-free sphere read as
// contrast 0.08, grain 2.7 lines, and its centres then smoothed over 12 lines).
TraceLight RelativeLight(const std::vector<Candidate*>& members) {
  TraceLight out;
  out.lines.reserve(members.size());
  out.relative.reserve(members.size());
  for (size_t i = 0; i < members.size(); ++i) {
    const int line = members[i]->stripe.Line();
    std::array<double, 5> m{};
    std::array<double, 3> t{};
    const size_t from = i - std::min(i, static_cast<size_t>(kSpeckleTrendLines));
    for (size_t k = from; k < members.size(); ++k) {
      const int d = members[k]->stripe.Line() - line;
      if (d < -kSpeckleTrendLines) continue;
      if (d > kSpeckleTrendLines) break;
      AddMoments(d, members[k]->light, &m, &t);
    }
    const double trend = QuadraticAtZero(m, t, t[0] / m[0]);
    if (!(trend > 0.0)) continue;
    out.lines.push_back(line);
    out.relative.push_back(members[i]->light / trend - 1.0);
  }
  return out;
}

}  // namespace

SpeckleEstimate EstimateSpeckle(const std::vector<StripePoint>& points,
                                const EpipolarOptions& options) {
  constexpr int kMaxLag = 6;
  std::vector<Candidate> all;
  all.reserve(points.size());
  // The profile's light, not its peak pixel: the peak changes with the centre's sub-pixel phase.
  for (const StripePoint& s : points) all.push_back({s, 0.0, std::max(1.0, s.mass_dn)});
  std::vector<TraceLight> traces;
  for (const auto& [id, members] : Traces(all, options)) {
    if (members.size() < kSpeckleMinTraceLines) continue;
    traces.push_back(RelativeLight(members));
  }
  SpeckleEstimate out;
  std::vector<double> pooled;
  for (const TraceLight& t : traces)
    pooled.insert(pooled.end(), t.relative.begin(), t.relative.end());
  out.samples = pooled.size();
  if (pooled.empty()) return out;
  // A glint (a spot several times brighter, a few lines long) is no speckle: each residual is
  // clipped at 3 robust sigma (1.4826 times the median absolute residual), so a few lines of a
  // spot cannot pass for a grainy surface.
  for (double& r : pooled) r = std::abs(r);
  std::nth_element(pooled.begin(), pooled.begin() + static_cast<long>(pooled.size() / 2),
                   pooled.end());
  const double clip = 3.0 * 1.4826 * pooled[pooled.size() / 2];
  std::array<double, kMaxLag + 1> products{}, pairs{};
  for (const TraceLight& t : traces) {
    for (size_t i = 0; i < t.lines.size(); ++i) {
      for (size_t k = i; k < t.lines.size(); ++k) {
        const int lag = t.lines[k] - t.lines[i];
        if (lag > kMaxLag) break;
        products[static_cast<size_t>(lag)] +=
            std::clamp(t.relative[i], -clip, clip) * std::clamp(t.relative[k], -clip, clip);
        pairs[static_cast<size_t>(lag)] += 1.0;
      }
    }
  }
  if (pairs[0] < 1.0) return out;
  const double variance = products[0] / pairs[0];
  out.contrast = std::sqrt(variance);
  out.grain_lines = kMaxLag;
  double before = 1.0;
  for (int lag = 1; lag <= kMaxLag; ++lag) {
    if (pairs[static_cast<size_t>(lag)] < 1.0 || !(variance > 0.0)) break;
    const double rho =
        products[static_cast<size_t>(lag)] / pairs[static_cast<size_t>(lag)] / variance;
    if (rho < 0.5) {
      out.grain_lines = lag - 1 + (before - 0.5) / (before - rho);
      break;
    }
    before = rho;
  }
  return out;
}

double AlongStripeSigmaPx(const SpeckleEstimate& speckle) {
  constexpr std::size_t kMinSamples = 200;
  if (speckle.samples < kMinSamples || speckle.contrast < kMinSpeckleContrast) return 0.0;
  return std::clamp(2.0 * speckle.grain_lines, 1.0, 4.0);
}

int SmoothHalfLines(const SpeckleEstimate& speckle, int plain) {
  if (AlongStripeSigmaPx(speckle) == 0.0) return plain;
  return std::clamp(static_cast<int>(std::ceil(8.0 * speckle.grain_lines)), plain, 12);
}

void KeepOneDirectPerEpipolarLine(const ProbeModel& model,
                                  const std::vector<StripePoint>& rejected,
                                  const EpipolarOptions& options,
                                  std::vector<StripePoint>* points,
                                  EpipolarCounts* counts) {
  const EpipolarIndex index(model);
  std::vector<Candidate> all;
  all.reserve(points->size() + rejected.size());
  for (const StripePoint& s : *points)
    all.push_back({s, index.Of(s), std::max(1.0, s.amplitude_dn), false});
  // A saturated stripe's light is at least its clipped peak's.
  for (const StripePoint& s : rejected)
    all.push_back({s, index.Of(s), std::max(1.0, s.amplitude_dn), true});
  const auto traces = Traces(all, options);
  Decide(all, traces, options);
  // A trace of a few lines has nothing along the stripe to hold it: a speckle grain, or a
  // reflection's fragment where the stripe is missing.
  for (const auto& [id, members] : traces) {
    if (static_cast<int>(members.size()) >= options.min_trace_lines) continue;
    for (Candidate* m : members) {
      if (m->drop == Drop::kKept) m->drop = Drop::kIsolated;
    }
  }
  counts->smoothed += FitAlongTraces(all, options.smooth_half_lines);
  points->clear();
  for (const Candidate& c : all) {
    if (c.rejected) continue;
    switch (c.drop) {
      case Drop::kKept:
        points->push_back(c.stripe);
        break;
      case Drop::kWeaker:
        ++counts->second_on_line;
        break;
      case Drop::kUndecided:
        ++counts->undecided;
        break;
      case Drop::kBesideRejected:
        ++counts->beside_rejected;
        break;
      case Drop::kIsolated:
        ++counts->isolated;
        break;
    }
  }
}

}  // namespace mlp::probe_fw
