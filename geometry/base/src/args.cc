#include "mlp/base/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace mlp::base {

Args::Args(const std::vector<std::string>& args, const ArgSpec& spec) {
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (spec.switches.count(a)) {
      switches_.insert(a);
      continue;
    }
    const bool option = a.size() > 1 && a[0] == '-';
    if (!option && spec.positionals) {
      positionals_.push_back(a);
      continue;
    }
    const bool repeated = spec.repeated.count(a) > 0;
    if (!repeated && !spec.valued.count(a)) throw UsageError("unknown argument '" + a + "'");
    if (i + 1 >= args.size()) throw UsageError(a + " needs a value");
    const std::string& v = args[++i];
    if (repeated) {
      repeated_[a].push_back(v);
    } else if (!values_.emplace(a, v).second) {
      throw UsageError(a + " is given twice");
    }
  }
}

bool Args::Has(const std::string& name) const {
  return values_.count(name) || switches_.count(name) || repeated_.count(name);
}

const std::string& Args::Text(const std::string& name) const {
  const auto it = values_.find(name);
  if (it == values_.end()) throw UsageError(name + " is required");
  return it->second;
}

std::string Args::Text(const std::string& name, const std::string& fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : it->second;
}

double Args::Number(const std::string& name) const { return ParseNumber(name, Text(name)); }

double Args::Number(const std::string& name, double fallback) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : ParseNumber(name, it->second);
}

long long Args::Integer(const std::string& name, long long fallback, long long min) const {
  const auto it = values_.find(name);
  return it == values_.end() ? fallback : ParseInteger(name, it->second, min);
}

const std::vector<std::string>& Args::All(const std::string& name) const {
  static const std::vector<std::string> kNone;
  const auto it = repeated_.find(name);
  return it == repeated_.end() ? kNone : it->second;
}

double ParseNumber(const std::string& name, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v))
    throw UsageError(name + " needs a number, got '" + text + "'");
  return v;
}

std::vector<double> ParseNumberList(const std::string& name, const std::string& text) {
  std::vector<double> out;
  std::stringstream s(text);
  for (std::string item; std::getline(s, item, ',');) out.push_back(ParseNumber(name, item));
  if (out.empty()) throw UsageError(name + " needs numbers separated by commas");
  return out;
}

long long ParseInteger(const std::string& name, const std::string& text, long long min) {
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || v < min)
    throw UsageError(name + " needs a whole number >= " + std::to_string(min) + ", got '" + text +
                     "'");
  return v;
}

}  // namespace mlp::base
