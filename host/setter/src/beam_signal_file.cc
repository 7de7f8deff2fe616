#include "mlp/setter/beam_signal_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <iomanip>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

namespace mlp::setter {
namespace {

constexpr const char* kHeader = "# mlprobe-beam-signal/1 sample_rate_hz=";
constexpr const char* kHeader2 = "# mlprobe-beam-signal/2 ";

[[noreturn]] void Bad(const std::string& where, long line, const std::string& what) {
  throw SetterInputError(where + (line > 0 ? ":" + std::to_string(line) : "") + ": " + what);
}

// `key=value` pairs of the /2 header, numbers only.
std::map<std::string, double> HeaderFields(const std::string& line, const std::string& where) {
  std::map<std::string, double> out;
  std::istringstream in(line.substr(std::strlen(kHeader2)));
  std::string field;
  while (in >> field) {
    const auto eq = field.find('=');
    char* end = nullptr;
    const double v = eq == std::string::npos ? 0 : std::strtod(field.c_str() + eq + 1, &end);
    if (eq == std::string::npos || end == field.c_str() + eq + 1 || *end != '\0' ||
        !std::isfinite(v))
      Bad(where, 1, "header field '" + field + "' is not key=number");
    out[field.substr(0, eq)] = v;
  }
  return out;
}

const std::set<std::string> kColumns = {"t_s", "code", "volts", "axis_mm", "latch", "index"};

std::vector<std::string> Columns(const std::string& line, const std::string& where) {
  std::istringstream in(line.substr(std::strlen("# columns:")));
  std::vector<std::string> cols;
  std::string c;
  while (in >> c) {
    if (!kColumns.count(c) || std::count(cols.begin(), cols.end(), c))
      Bad(where, 2, "unknown or repeated column '" + c + "' (t_s code volts axis_mm latch index)");
    cols.push_back(c);
  }
  if (std::count(cols.begin(), cols.end(), "code") +
          std::count(cols.begin(), cols.end(), "volts") !=
      1)
    Bad(where, 2, "the columns need exactly one of code and volts");
  return cols;
}

// One /2 sample line into the signal; `t0` the first timestamp (NaN before).
void AddSample(const std::vector<std::string>& cols,
               const std::string& line,
               long n,
               double lsb,
               long max_code,
               double* t0,
               BeamSignal* s,
               const std::string& where) {
  std::istringstream in(line);
  const long i = static_cast<long>(s->volts.size());
  for (const std::string& c : cols) {
    std::string text;
    if (!(in >> text)) Bad(where, n, "expected " + std::to_string(cols.size()) + " columns");
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
      Bad(where, n, c + " is not a number");
    if (c == "code") {
      if (v != std::floor(v) || v < 0 || v > static_cast<double>(max_code))
        Bad(where, n, "code " + text + " is not a whole number within the ADC's bits");
      s->volts.push_back(static_cast<float>(v * lsb));
      if (static_cast<long>(v) == max_code) ++s->saturated;
    } else if (c == "volts") {
      s->volts.push_back(static_cast<float>(v));
    } else if (c == "t_s") {
      if (std::isnan(*t0)) *t0 = v;
      const double expected = *t0 + static_cast<double>(i) / s->sample_rate_hz;
      if (std::abs(v - expected) > 0.02 / s->sample_rate_hz)
        Bad(where, n, "timestamp " + text + " is not 1/sample_rate after the last: samples lost?");
    } else if (c == "axis_mm") {
      s->axis_mm.push_back(v);
    } else {
      if (v != 0 && v != 1) Bad(where, n, c + " must be 0 or 1");
      (c == "latch" ? s->latch : s->index).push_back(static_cast<char>(v));
    }
  }
}

BeamSignal ParseV2(std::istringstream& in, const std::string& header, const std::string& where) {
  const auto h = HeaderFields(header, where);
  const auto get = [&](const char* k) { return h.count(k) ? h.at(k) : 0.0; };
  BeamSignal s;
  s.sample_rate_hz = get("sample_rate_hz");
  s.amplifier_hz = get("amplifier_hz");
  const double bits = get("adc_bits"), full_scale = get("full_scale_v");
  if (!(s.sample_rate_hz > 0)) Bad(where, 1, "no sample_rate_hz");
  if (!(bits >= 8 && bits <= 24 && bits == std::floor(bits)) || !(full_scale > 0))
    Bad(where, 1, "adc_bits (8..24) and full_scale_v (> 0) are required");
  if (!(s.amplifier_hz >= 0)) Bad(where, 1, "amplifier_hz must be >= 0");
  const long max_code = (1L << static_cast<int>(bits)) - 1;
  std::string line;
  if (!std::getline(in, line) || line.rfind("# columns:", 0) != 0)
    Bad(where, 2, "the second line must be '# columns: ...'");
  const std::vector<std::string> cols = Columns(line, where);
  double t0 = std::numeric_limits<double>::quiet_NaN();
  long n = 2;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    AddSample(cols, line, n, full_scale / static_cast<double>(max_code + 1), max_code, &t0, &s,
              where);
  }
  return s;
}

}  // namespace

std::string BeamSignalText(const BeamSignal& s) {
  std::ostringstream text;
  text << kHeader << s.sample_rate_hz << "\n" << std::setprecision(7);
  for (float v : s.volts) text << v << "\n";
  return text.str();
}

BeamSignal ParseBeamSignal(const std::string& text, const std::string& where) {
  std::istringstream in(text);
  BeamSignal s;
  std::string line;
  if (std::getline(in, line) && line.rfind(kHeader2, 0) == 0) return ParseV2(in, line, where);
  if (line.rfind(kHeader, 0) != 0)
    throw SetterInputError(where + ": not a mlprobe-beam-signal/1 or /2 file");
  s.sample_rate_hz = std::atof(line.substr(line.find('=') + 1).c_str());
  if (!(s.sample_rate_hz > 0) || !std::isfinite(s.sample_rate_hz))
    throw SetterInputError(where + ": no sample rate");
  long n = 1;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    char* end = nullptr;
    const double v = std::strtod(line.c_str(), &end);
    if (end == line.c_str() || !std::isfinite(v))
      throw SetterInputError(where + ":" + std::to_string(n) + ": not a voltage");
    s.volts.push_back(static_cast<float>(v));
  }
  return s;
}

std::string BeamTruthJson(const BeamSignal& s) {
  const nlohmann::ordered_json truth = {{"format", "mlprobe-beam-truth/1"},
                                        {"axis_start_mm", s.axis_start_mm},
                                        {"axis_feed_mm_per_sample", s.axis_feed_mm_per_sample},
                                        {"axis_at_edge_mm", s.axis_at_edge_mm},
                                        {"drop_times_s", s.drop_times_s}};
  return truth.dump(1) + "\n";
}

}  // namespace mlp::setter
