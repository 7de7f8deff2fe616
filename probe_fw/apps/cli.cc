#include "cli.h"

#include "mlp/probe_fw/roi_spec.h"

#include <cmath>
#include <sstream>

namespace mlp::probe_fw::cli {

Options::Options(const std::vector<std::string>& args,
                 const std::set<std::string>& with_value,
                 const std::set<std::string>& flags) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (flags.count(a)) {
      flags_.insert(a);
    } else if (with_value.count(a)) {
      if (i + 1 >= args.size()) throw UsageError(a + " needs a value");
      values_[a] = args[++i];
    } else {
      throw UsageError("unknown argument '" + a + "'");
    }
  }
}

std::string Options::Required(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) throw UsageError(name + " is required");
  return it->second;
}

std::string Options::Get(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

double Options::Number(const std::string& name, double fallback) const {
  const auto it = values_.find(name);
  if (it == values_.end()) return fallback;
  size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(it->second, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != it->second.size() || !std::isfinite(v)) throw UsageError(name + " must be a number");
  return v;
}

Aoi ParseAoi(const std::string& text) {
  try {
    return probe_fw::ParseAoi(text);
  } catch (const RoiError& e) {
    throw UsageError(e.what());
  }
}

}  // namespace mlp::probe_fw::cli
