#include "mlp/probe_fw/cli.h"

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
  std::istringstream in(text);
  Aoi a;
  char c1 = 0, c2 = 0, c3 = 0;
  if (!(in >> a.x0 >> c1 >> a.y0 >> c2 >> a.width >> c3 >> a.height) || c1 != ',' || c2 != ',' ||
      c3 != ',' || !(in >> std::ws).eof() || a.x0 < 0 || a.y0 < 0 || a.width <= 0 ||
      a.height <= 0) {
    throw UsageError("an AOI is x0,y0,width,height in pixels, got '" + text + "'");
  }
  return a;
}

}  // namespace mlp::probe_fw::cli
