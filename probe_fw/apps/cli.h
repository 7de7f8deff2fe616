#pragma once
/// @file Command-line plumbing of the probe programs (mlp-fw, mlp-sim; linked into programs
/// only, never into a library): options of the form
/// `--name value` and `--flag`, and the exit codes they share with `mlp` (docs/CLI.md).

#include "mlp/probe_fw/frame.h"

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::probe_fw::cli {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;   ///< an internal error (a bug): report it
constexpr int kExitBadInput = 2;  ///< bad arguments or input files; nothing was written
constexpr int kExitNoDevice = 3;  ///< the camera is missing or failed

class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Options {
 public:
  /// Throws UsageError on an unknown option or a missing value.
  Options(const std::vector<std::string>& args,
          const std::set<std::string>& with_value,
          const std::set<std::string>& flags);
  std::string Required(const std::string& name) const;
  std::string Get(const std::string& name, const std::string& fallback) const;
  bool Has(const std::string& name) const {
    return values_.count(name) > 0 || flags_.count(name) > 0;
  }
  double Number(const std::string& name, double fallback) const;

 private:
  std::map<std::string, std::string> values_;
  std::set<std::string> flags_;
};

/// "x0,y0,width,height" in sensor pixels (probe_fw::ParseAoi, its RoiError as UsageError).
Aoi ParseAoi(const std::string& text);

}  // namespace mlp::probe_fw::cli
