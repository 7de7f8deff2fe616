#include "mlp/setter/beam_signal_file.h"

#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <sstream>

#include <nlohmann/json.hpp>

namespace mlp::setter {
namespace {

constexpr const char* kHeader = "# mlprobe-beam-signal/1 sample_rate_hz=";

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
  if (!std::getline(in, line) || line.rfind(kHeader, 0) != 0)
    throw SetterInputError(where + ": not a mlprobe-beam-signal/1 file");
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
