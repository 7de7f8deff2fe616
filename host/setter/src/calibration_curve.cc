#include "mlp/setter/calibration_curve.h"

#include "mlp/base/json_fields.h"
#include "mlp/setter/beam_signal.h"
#include "mlp/setter/rise.h"

#include <algorithm>
#include <cmath>

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

double CalibrationCurve::Share(double x) const { return c[0] + x * (c[1] + x * (c[2] + x * c[3])); }

double CalibrationCurve::IntrusionAt(double share) const {
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
    const double slope = c[1] + x * (2 * c[2] + 3 * x * c[3]);
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
  return cur;
}

std::string CurveJson(const CalibrationCurve& c) {
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

CalibrationCurve ParseCurve(const std::string& text, const std::string& where) {
  namespace jf = base::json_fields;
  using E = SetterInputError;
  const auto j = jf::ParseDocument<E>(text, "mlprobe-beam-curve/1", where);
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
  return c;
}

}  // namespace mlp::setter
