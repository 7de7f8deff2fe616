#include "mlp/setter/calibration_curve.h"

#include "mlp/base/json_fields.h"
#include "mlp/setter/beam_signal.h"
#include "mlp/setter/rise.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <nlohmann/json.hpp>

namespace mlp::setter {
namespace {

[[noreturn]] void Fail(const std::string& what) { throw SetterError("calibration curve: " + what); }

constexpr double kShareHi = 0.9, kShareLo = 0.1;  // the span fitted

double Median(std::vector<float> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

double CalibrationCurve::Share(double x) const {
  if (table.empty()) return c[0] + x * (c[1] + x * (c[2] + x * c[3]));
  const double f =
      std::clamp((x - table_x0_mm) / table_step_mm, 0.0, static_cast<double>(table.size() - 1));
  const auto i = std::min(static_cast<size_t>(f), table.size() - 2);
  return table[i] + (table[i + 1] - table[i]) * (f - static_cast<double>(i));
}

double CalibrationCurve::Slope(double x) const {
  if (table.empty()) return c[1] + x * (2 * c[2] + 3 * x * c[3]);
  const double h = 2 * table_step_mm;  // over four steps: the table's bins are noisy
  const double a = std::max(lo_mm, x - h), b = std::min(hi_mm, x + h);
  return (Share(b) - Share(a)) / (b - a);
}

double CalibrationCurve::IntrusionAt(double share) const {
  if (!table.empty()) {  // falling strictly: the bins bracketing the share
    if (share >= table.front()) return lo_mm;
    if (share <= table.back()) return hi_mm;
    const auto it = std::lower_bound(table.begin(), table.end(), share, std::greater<double>());
    const auto i = static_cast<size_t>(it - table.begin());  // table[i] <= share < table[i-1]
    const double f = (table[i - 1] - share) / (table[i - 1] - table[i]);
    return table_x0_mm + (static_cast<double>(i - 1) + f) * table_step_mm;
  }
  // The curve falls over [lo, hi]: bisection, then two Newton steps.
  if (share >= Share(lo_mm)) return lo_mm;
  if (share <= Share(hi_mm)) return hi_mm;
  double a = lo_mm, b = hi_mm;
  for (int i = 0; i < 40; ++i) {
    const double m = (a + b) / 2;
    (Share(m) > share ? a : b) = m;
  }
  double x = (a + b) / 2;
  for (int i = 0; i < 2; ++i) {
    const double slope = Slope(x);
    if (slope < 0) x = std::clamp(x - (Share(x) - share) / slope, lo_mm, hi_mm);
  }
  return x;
}

namespace {

// The rise p before the fall (rise.h): the highest average before it, over 6 times the
// averaged clear signal's scatter, its bump's peak through RiseFinder; x from the half-light
// crossing as the curve's.
void FindRise(const std::vector<double>& avg,
              size_t clear_n,
              size_t fall,
              double t50,
              double mm_per_sample,
              double fs,
              CalibrationCurve* cur) {
  double sum = 0, sum2 = 0, peak = 0;
  for (size_t i = 4; i < clear_n; ++i) sum += avg[i], sum2 += avg[i] * avg[i];
  const double n = static_cast<double>(clear_n - 4), mean = sum / n;
  const double scatter = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  for (size_t i = 4; i < fall; ++i) peak = std::max(peak, avg[i] - 1.0);
  if (!(peak > 6 * scatter)) return;
  RiseFinder rise(peak / 2, kRiseMinS);
  for (size_t i = 4; i < fall && !rise.Found(); ++i) rise.Add(static_cast<double>(i) / fs, avg[i]);
  if (!rise.Found()) return;
  cur->rise_share = peak;
  cur->rise_mm = (rise.PeakTimeS() * fs - t50) * mm_per_sample;
}

// The cubic through the (x, share) samples, its span, and the check that it falls throughout.
void FitCubic(const std::vector<std::pair<double, double>>& pts, CalibrationCurve* cur) {
  if (pts.size() < 50) Fail("fewer than 50 samples between 90 % and 10 %: feed too fast");
  Eigen::MatrixXd a(static_cast<Eigen::Index>(pts.size()), 4);
  Eigen::VectorXd b(static_cast<Eigen::Index>(pts.size()));
  double lo = 1e300, hi = -1e300;
  for (size_t i = 0; i < pts.size(); ++i) {
    const double x = pts[i].first;
    a.row(static_cast<Eigen::Index>(i)) << 1, x, x * x, x * x * x;
    b(static_cast<Eigen::Index>(i)) = pts[i].second;
    lo = std::min(lo, x), hi = std::max(hi, x);
  }
  const Eigen::Vector4d coef = a.colPivHouseholderQr().solve(b);
  for (int k = 0; k < 4; ++k) cur->c[k] = coef(k);
  cur->rms = std::sqrt((a * coef - b).squaredNorm() / static_cast<double>(pts.size()));
  cur->samples = static_cast<int>(pts.size());
  // The span: from the first 90 % to the last 10 % crossing of the fitted curve.
  cur->lo_mm = lo, cur->hi_mm = hi;
  for (double x = lo; x <= hi; x += (hi - lo) / 200)
    if (cur->c[1] + x * (2 * cur->c[2] + 3 * x * cur->c[3]) >= 0)
      Fail("the fitted curve is not falling over its span (a drop during the calibration?)");
}

// Pool-adjacent-violators: the least-squares non-increasing sequence through `y` (weights
// `n`), written here as no Debian C++ library offers isotonic regression; then strictly
// falling by a hair, so that every share has one intrusion.
void MakeFalling(std::vector<double>* y, std::vector<double> n) {
  std::vector<double> value, weight;
  std::vector<size_t> count;
  for (size_t i = 0; i < y->size(); ++i) {
    value.push_back((*y)[i]), weight.push_back(n[i]), count.push_back(1);
    while (value.size() > 1 && value[value.size() - 2] < value.back()) {
      const size_t k = value.size() - 1;
      value[k - 1] =
          (value[k - 1] * weight[k - 1] + value[k] * weight[k]) / (weight[k - 1] + weight[k]);
      weight[k - 1] += weight[k], count[k - 1] += count[k];
      value.pop_back(), weight.pop_back(), count.pop_back();
    }
  }
  size_t i = 0;
  for (size_t b = 0; b < value.size(); ++b)
    for (size_t k = 0; k < count[b]; ++k) (*y)[i++] = value[b];
  for (size_t k = 1; k < y->size(); ++k) (*y)[k] = std::min((*y)[k], (*y)[k - 1] - 1e-7);
}

// The table: the raw shares binned by intrusion (bins of 0.25 um, at least 5 samples each)
// from the rise's peak (without a rise, where the average first falls under 99.5 %) to where
// it falls under 2 %, each bin's mean, from the last at 100 % on, made falling.
void FillTable(const std::vector<double>& share,
               const std::vector<double>& avg,
               size_t clear_n,
               size_t cross,
               double t50,
               double mm_per_sample,
               CalibrationCurve* cur) {
  size_t start = cross;
  if (cur->rise_share > 0)  // from the rise's peak (RiseFinder's, not the noisy average's)
    start = static_cast<size_t>(
        std::clamp(t50 + cur->rise_mm / mm_per_sample, static_cast<double>(clear_n), t50));
  else  // no rise above the noise: the wing from 99.5 %
    while (start > clear_n && avg[start - 1] < 0.995) --start;
  size_t end = cross;
  while (end + 1 < avg.size() && avg[end + 1] > 0.02) ++end;
  const double step = std::max(0.00025, 5 * mm_per_sample);
  const double x0 = (static_cast<double>(start) - t50) * mm_per_sample;
  const auto bins =
      static_cast<size_t>(std::floor((static_cast<double>(end - start) * mm_per_sample) / step));
  if (bins < 8) Fail("fewer than 8 table bins over the fall: the feed was too fast for the beam");
  std::vector<double> sum(bins, 0.0), n(bins, 0.0);
  for (size_t i = start; i <= end; ++i) {
    const auto b = static_cast<size_t>(
        std::floor(((static_cast<double>(i) - t50) * mm_per_sample - x0) / step));
    if (b < bins) sum[b] += share[i], n[b] += 1;
  }
  for (size_t b = 0; b < bins; ++b) {
    if (n[b] == 0) Fail("an empty bin in the table (samples missing?)");
    sum[b] /= n[b];
  }
  // Above the clear level the rise's ripple is not one-to-one: the table starts at the last
  // bin at 100 % or more before half the light (the wing from there down).
  size_t first = 0;
  for (size_t b = 0; b < bins && sum[b] > 0.5; ++b)
    if (sum[b] >= 1.0) first = b;
  sum.erase(sum.begin(), sum.begin() + static_cast<std::ptrdiff_t>(first));
  n.erase(n.begin(), n.begin() + static_cast<std::ptrdiff_t>(first));
  if (sum.size() < 8) Fail("fewer than 8 table bins below the clear level");
  MakeFalling(&sum, n);
  cur->table = sum;
  cur->table_step_mm = step;
  cur->table_x0_mm = x0 + step * (static_cast<double>(first) + 0.5);  // bins' centres
  cur->lo_mm = cur->table_x0_mm;
  cur->hi_mm = cur->table_x0_mm + step * static_cast<double>(sum.size() - 1);
}

// The beam's 1/e^2 radius as a Gaussian's from the 90 % and 10 % crossings (2 x 0.6408 w
// apart), and the half-light point's standard uncertainty: the clear level's noise over the
// slope there, averaged over the samples within one step of it.
void Describe(double noise_share, double mm_per_sample, CalibrationCurve* cur) {
  cur->beam_radius_mm = (cur->IntrusionAt(0.1) - cur->IntrusionAt(0.9)) / 1.2816;
  const double slope = std::abs(cur->Slope(cur->IntrusionAt(0.5)));
  const double samples = std::max(1.0, cur->table_step_mm / mm_per_sample);
  cur->half_light_u_mm = slope > 0 ? noise_share / slope / std::sqrt(samples) : 0.0;
}

double NoiseShare(const std::vector<double>& share, size_t clear_n) {
  double sum = 0, sum2 = 0;
  for (size_t i = 0; i < clear_n; ++i) sum += share[i], sum2 += share[i] * share[i];
  const double n = static_cast<double>(clear_n), mean = sum / n;
  return std::sqrt(std::max(0.0, sum2 / n - mean * mean));
}

}  // namespace

CalibrationCurve CalibrateFromPin(const std::vector<float>& volts,
                                  double fs,
                                  double feed_mm_min,
                                  bool entering,
                                  bool reflective) {
  const auto clear_n = static_cast<size_t>(0.02 * fs);
  if (!(fs > 0) || !(feed_mm_min > 0) || volts.size() < 4 * clear_n)
    throw SetterInputError(
        "calibration curve: needs a sample rate, a feed and at least 80 ms of signal");
  CalibrationCurve cur;
  // The level: the clear beam before the pin (transmissive), the full reflection with the pin
  // in (reflective).
  const bool level_first = entering != reflective;
  cur.clear_v = level_first ? Median({volts.begin(), volts.begin() + static_cast<long>(clear_n)})
                            : Median({volts.end() - static_cast<long>(clear_n), volts.end()});
  if (!(cur.clear_v > 0))
    Fail(reflective ? "no reflection with the pin in the beam" : "the beam is dark before the pin");
  // Shares in time order as the pin goes in (a leaving pin read backwards).
  std::vector<double> share(volts.size());
  for (size_t i = 0; i < volts.size(); ++i)
    share[entering ? i : volts.size() - 1 - i] =
        reflective ? 1.0 - volts[i] / cur.clear_v : volts[i] / cur.clear_v;
  // A 9-sample average against the noise: the half-light crossing on it (interpolated), and
  // the transition round it (from 95 % to 5 %) as the span that is fitted: a drop elsewhere
  // stays out.
  std::vector<double> avg(share.size(), 1.0);
  for (size_t i = 4; i + 4 < share.size(); ++i) {
    double sum = 0;
    for (size_t k = i - 4; k <= i + 4; ++k) sum += share[k];
    avg[i] = sum / 9;
  }
  size_t cross = 0;
  while (cross + 1 < avg.size() && !(avg[cross] >= 0.5 && avg[cross + 1] < 0.5)) ++cross;
  if (cross + 1 >= avg.size()) Fail("the pin never blocked half the beam");
  const double t50 =
      static_cast<double>(cross) + (avg[cross] - 0.5) / (avg[cross] - avg[cross + 1]);
  size_t first = cross, last = cross;
  while (first > 0 && avg[first - 1] < 0.95) --first;
  while (last + 1 < avg.size() && avg[last + 1] > 0.05) ++last;
  const double mm_per_sample = feed_mm_min / 60 / fs;
  if (!reflective) FindRise(avg, clear_n, first, t50, mm_per_sample, fs, &cur);
  std::vector<std::pair<double, double>> pts;  // (x, share)
  for (size_t i = first; i <= last; ++i)
    if (share[i] <= kShareHi && share[i] >= kShareLo)
      pts.emplace_back((static_cast<double>(i) - t50) * mm_per_sample, share[i]);
  FitCubic(pts, &cur);
  cur.feed_mm_min = feed_mm_min, cur.sample_rate_hz = fs;
  FillTable(share, avg, clear_n, cross, t50, mm_per_sample, &cur);
  Describe(NoiseShare(share, clear_n), mm_per_sample, &cur);
  return cur;
}

std::string CurveJson(const CalibrationCurve& c) {
  if (!c.table.empty()) {
    const nlohmann::ordered_json j = {
        {"format", "mlprobe-beam-curve/2"},
        {"clear_v", c.clear_v},
        {"lo_mm", c.lo_mm},
        {"hi_mm", c.hi_mm},
        {"table_x0_mm", c.table_x0_mm},
        {"table_step_mm", c.table_step_mm},
        {"table_share", c.table},
        {"cubic", {c.c[0], c.c[1], c.c[2], c.c[3]}},
        {"rms_share", c.rms},
        {"samples", c.samples},
        {"rise_share", c.rise_share},
        {"rise_mm", c.rise_mm},
        {"feed_mm_min", c.feed_mm_min},
        {"sample_rate_hz", c.sample_rate_hz},
        {"filter", "9-sample average for the crossing; raw samples binned"},
        {"pin_diameter_mm", c.pin_diameter_mm},
        {"beam_radius_mm", c.beam_radius_mm},
        {"divergence", "unknown: one pass of the pin measures the beam at one place"},
        {"half_light_u_mm", c.half_light_u_mm},
        {"date_utc", c.date_utc},
        {"serial", c.serial}};
    return j.dump(1) + "\n";
  }
  const nlohmann::ordered_json j = {{"format", "mlprobe-beam-curve/1"},
                                    {"clear_v", c.clear_v},
                                    {"lo_mm", c.lo_mm},
                                    {"hi_mm", c.hi_mm},
                                    {"cubic", {c.c[0], c.c[1], c.c[2], c.c[3]}},
                                    {"rms_share", c.rms},
                                    {"samples", c.samples},
                                    {"rise_share", c.rise_share},
                                    {"rise_mm", c.rise_mm}};
  return j.dump(1) + "\n";
}

namespace {

// The /2 table and what it was made from; the table must fall strictly over lo..hi.
void ParseTable(const nlohmann::json& j, const std::string& where, CalibrationCurve* c) {
  namespace jf = base::json_fields;
  using E = SetterInputError;
  c->table_x0_mm = jf::Number<E>(j, "table_x0_mm", where);
  c->table_step_mm = jf::Number<E>(j, "table_step_mm", where);
  if (!j.contains("table_share") || !j.at("table_share").is_array())
    throw E(where + ": table_share must be an array of numbers");
  for (const auto& v : j.at("table_share")) {
    if (!v.is_number() || !std::isfinite(v.get<double>()))
      throw E(where + ": table_share must be an array of numbers");
    c->table.push_back(v.get<double>());
  }
  if (c->table.size() < 8 || !(c->table_step_mm > 0) ||
      std::adjacent_find(c->table.begin(), c->table.end(), std::less_equal<double>()) !=
          c->table.end())
    throw E(where + ": table_share must hold 8 or more shares, falling strictly, step > 0");
  const double end = c->table_x0_mm + c->table_step_mm * static_cast<double>(c->table.size() - 1);
  if (std::abs(c->lo_mm - c->table_x0_mm) > 1e-9 || std::abs(c->hi_mm - end) > 1e-9)
    throw E(where + ": lo_mm and hi_mm must be the table's first and last intrusion");
  c->feed_mm_min = jf::NumberOr<E>(j, "feed_mm_min", 0.0, where);
  c->sample_rate_hz = jf::NumberOr<E>(j, "sample_rate_hz", 0.0, where);
  c->pin_diameter_mm = jf::NumberOr<E>(j, "pin_diameter_mm", 0.0, where);
  c->beam_radius_mm = jf::NumberOr<E>(j, "beam_radius_mm", 0.0, where);
  c->half_light_u_mm = jf::NumberOr<E>(j, "half_light_u_mm", 0.0, where);
  if (j.contains("date_utc") && j.at("date_utc").is_string()) c->date_utc = j.at("date_utc");
  if (j.contains("serial") && j.at("serial").is_string()) c->serial = j.at("serial");
}

}  // namespace

CalibrationCurve ParseCurve(const std::string& text, const std::string& where) {
  namespace jf = base::json_fields;
  using E = SetterInputError;
  const auto j =
      jf::ParseDocument<E>(text, {"mlprobe-beam-curve/2", "mlprobe-beam-curve/1"}, where);
  CalibrationCurve c;
  c.clear_v = jf::Number<E>(j, "clear_v", where);
  c.lo_mm = jf::Number<E>(j, "lo_mm", where);
  c.hi_mm = jf::Number<E>(j, "hi_mm", where);
  const auto cubic_bad = [&] {
    if (!j.contains("cubic") || !j.at("cubic").is_array() || j.at("cubic").size() != 4) return true;
    return !std::all_of(j.at("cubic").begin(), j.at("cubic").end(),
                        [](const auto& x) { return x.is_number(); });
  };
  if (cubic_bad()) throw E(where + ": cubic must hold 4 numbers");
  for (int k = 0; k < 4; ++k) c.c[k] = j.at("cubic")[static_cast<size_t>(k)].get<double>();
  c.rms = jf::NumberOr<E>(j, "rms_share", 0.0, where);
  c.rise_share = jf::NumberOr<E>(j, "rise_share", 0.0, where);
  c.rise_mm = jf::NumberOr<E>(j, "rise_mm", 0.0, where);
  if (!(c.rise_share >= 0 && c.rise_share < 0.2) || !(std::abs(c.rise_mm) < 1))
    throw E(where + ": rise_share 0..0.2, |rise_mm| < 1");
  if (!(c.clear_v > 0) || !(c.hi_mm > c.lo_mm)) throw E(where + ": clear_v > 0, hi > lo");
  if (j.at("format") == "mlprobe-beam-curve/2") ParseTable(j, where, &c);
  return c;
}

}  // namespace mlp::setter
