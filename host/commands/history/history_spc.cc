// `mlp history spc`: a measured feature's process capability from the history (issue 22's SPC
// view): per characteristic (the feature with one nominal and one pair of limits; a request
// that changed them starts another), the last N parts' mean, sigma, Cp / Cpk, Pp / Ppk and
// control limits (jobs/spc.h), and a run chart as SVG.

#include "mlp/base/files.h"
#include "mlp/features/spc.h"
#include "mlp/history/history.h"
#include "mlp/host/cli.h"

#include <cmath>
#include <iomanip>
#include <map>
#include <ostream>
#include <sstream>
#include <tuple>

#include "history_commands.h"
#include <nlohmann/json.hpp>

namespace mlp::host {
namespace {

constexpr int kExitNoCapability = 3;

// One characteristic: the feature's nominal and limits, and its parts' values in time order.
struct Characteristic {
  std::string unit;  // "mm" or "deg"
  double nominal = 0, lower = 0, upper = 0;
  std::vector<double> values;
  std::vector<std::int64_t> jobs;
};

// The size, its nominal (size less the error) and the tolerance the request gave; nullopt for a
// result without them (a form-only feature).
std::optional<std::tuple<std::string, double, double, double, double>> Reading(
    const history::FeatureResult& r) {
  for (const std::string unit : {"mm", "deg"}) {
    const std::string size = "size_" + unit, error = "error_" + unit;
    if (!r.fit.contains(size) || !r.fit.contains(error) || !r.request.contains("tolerance"))
      continue;
    const auto& tol = r.request.at("tolerance");
    if (!tol.contains("upper_" + unit) || !tol.contains("lower_" + unit)) continue;
    const double value = r.fit.at(size).get<double>();
    const double nominal = value - r.fit.at(error).get<double>();
    return std::tuple{unit, value, nominal, nominal - tol.at("lower_" + unit).get<double>(),
                      nominal + tol.at("upper_" + unit).get<double>()};
  }
  return std::nullopt;
}

std::vector<Characteristic> Characteristics(const std::vector<history::FeatureResult>& results) {
  // Keyed by the limits rounded to 1 nm: the same drawing's numbers, read back from JSON.
  std::map<std::tuple<std::string, long long, long long>, Characteristic> by;
  std::vector<std::tuple<std::string, long long, long long>> order;
  for (const auto& r : results) {
    const auto reading = Reading(r);
    if (!reading) continue;
    const auto& [unit, value, nominal, lower, upper] = *reading;
    const auto key = std::tuple{unit, std::llround(lower * 1e6), std::llround(upper * 1e6)};
    auto [it, fresh] = by.try_emplace(key);
    if (fresh) {
      it->second = {unit, nominal, lower, upper, {}, {}};
      order.push_back(key);
    }
    it->second.values.push_back(value);
    it->second.jobs.push_back(r.job);
  }
  std::vector<Characteristic> out;
  out.reserve(order.size());
  for (const auto& k : order) out.push_back(by.at(k));
  return out;
}

nlohmann::json StudyJson(const Characteristic& c, const features::CapabilityStudy& s) {
  return {{"unit", c.unit},
          {"nominal", c.nominal},
          {"lower_limit", c.lower},
          {"upper_limit", c.upper},
          {"n", s.n},
          {"mean", s.mean},
          {"sigma_within", s.sigma_within},
          {"sigma_overall", s.sigma_overall},
          {"cp", s.cp},
          {"cpk", s.cpk},
          {"pp", s.pp},
          {"ppk", s.ppk},
          {"lcl", s.lcl},
          {"ucl", s.ucl},
          {"out_of_spec", s.out_of_spec},
          {"out_of_control_jobs",
           [&] {
             nlohmann::json a = nlohmann::json::array();
             for (int i : s.out_of_control) a.push_back(c.jobs[static_cast<size_t>(i)]);
             return a;
           }()},
          {"few_values", s.few_values},
          {"jobs", c.jobs},
          {"values", c.values}};
}

void PrintStudy(const std::string& feature,
                const Characteristic& c,
                const features::CapabilityStudy& s,
                std::ostream& out) {
  const double um = c.unit == "mm" ? 1e3 : 1.0;  // sigma in um for sizes
  const char* spread = c.unit == "mm" ? " um" : " deg";
  out << std::fixed << std::setprecision(4) << feature << " (nominal " << c.nominal << " " << c.unit
      << ", limits " << c.lower << " .. " << c.upper << "), the last " << s.n << " parts:\n  mean "
      << s.mean << " " << c.unit << ", sigma within " << std::setprecision(2) << s.sigma_within * um
      << spread << ", overall " << s.sigma_overall * um << spread << "\n  Cp " << s.cp << ", Cpk "
      << s.cpk << "; Pp " << s.pp << ", Ppk " << s.ppk << "; control limits "
      << std::setprecision(4) << s.lcl << " .. " << s.ucl << "\n  " << s.out_of_spec
      << " out of specification, " << s.out_of_control.size() << " beyond the control limits";
  if (!s.out_of_control.empty()) {
    out << " (jobs";
    for (int i : s.out_of_control) out << " " << c.jobs[static_cast<size_t>(i)];
    out << ")";
  }
  out << "\n";
  if (s.few_values)
    out << "  note: fewer than 25 parts: these figures are not yet a capability statement\n";
}

// The k-th characteristic's chart: FILE.svg, then FILE-2.svg, ... (a stream, not `+`: GCC 12
// warns falsely of overlapping copies, -Wrestrict, for the concatenation).
std::string ChartPath(const std::string& given, size_t k) {
  if (k == 0) return given;
  const size_t stem = given.size() - (given.ends_with(".svg") ? 4 : 0);
  std::ostringstream path;
  path << given.substr(0, stem) << "-" << k + 1 << given.substr(stem);
  return path.str();
}

}  // namespace

int RunHistorySpc(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const Args a(args, {{"--feature", "--machine", "--last", "--svg", "--db"}, {"--json"}});
  history::FeatureQuery q;
  q.feature = a.Text("--feature");
  if (a.Has("--machine")) q.machine = a.Text("--machine");
  q.last = static_cast<int>(std::min(a.Integer("--last", 50, 2), 100000LL));
  const std::vector<Characteristic> cs =
      Characteristics(OpenRecords(a.Text("--db", ""))->FeatureResults(q));
  if (cs.empty()) {
    err << "mlp history: no measured " << q.feature << " with a size and tolerance"
        << (q.machine ? " on " + *q.machine : std::string()) << "\n";
    return kExitNoCapability;
  }
  nlohmann::json all = nlohmann::json::array();
  int failed = 0;
  for (size_t k = 0; k < cs.size(); ++k) {
    const Characteristic& c = cs[k];
    try {
      const features::CapabilityStudy s = features::StudyCapability(c.values, {c.lower, c.upper});
      if (a.Has("--json"))
        all.push_back(StudyJson(c, s));
      else
        PrintStudy(q.feature, c, s, out);
      if (a.Has("--svg")) {  // one chart per characteristic: FILE.svg, then FILE-2.svg, ...
        const std::string path = ChartPath(a.Text("--svg"), k);
        base::WriteFileAtomically(
            path, features::RunChartSvg(c.values, {c.lower, c.upper}, s, q.feature, c.unit));
        if (!a.Has("--json")) out << "  run chart: " << path << "\n";
      }
    } catch (const features::SpcError& e) {
      err << "mlp history: " << q.feature << " (nominal " << c.nominal << "): " << e.what() << "\n";
      ++failed;
    }
  }
  if (a.Has("--json")) out << all.dump(2) << "\n";
  return failed == static_cast<int>(cs.size()) ? kExitNoCapability : kExitOk;
}

}  // namespace mlp::host
