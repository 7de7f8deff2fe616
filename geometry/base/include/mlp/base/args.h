#pragma once
/// @file The one command-line parser of every program (mlp, mlp-hostd, mlp-fw, mlp-sim, ...):
/// options `--name value` and switches `--name`, each declared by the command, and the exit
/// codes all programs share (docs/CLI.md). Anything undeclared, a missing value, a value given
/// twice or a number that is not a whole finite number is a UsageError naming the option: a
/// macro's typo is refused, never ignored.

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlp::base {

/// Exit codes every program shares; a program adds its own from 3 up (docs/CLI.md).
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,  ///< a bug: please report
  kExitBadInput = 2,  ///< unusable arguments, file or points; nothing was written
};

/// Unusable arguments: the program prints the reason and its usage, and exits kExitBadInput.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a command accepts.
struct ArgSpec {
  ArgSpec(std::set<std::string> valued_options = {},
          std::set<std::string> switch_options = {},
          std::set<std::string> repeated_options = {},
          bool allow_positionals = false)
      : valued(std::move(valued_options)),
        switches(std::move(switch_options)),
        repeated(std::move(repeated_options)),
        positionals(allow_positionals) {}

  std::set<std::string> valued;    ///< `--name value`, at most once
  std::set<std::string> switches;  ///< `--name`
  std::set<std::string> repeated;  ///< `--name value`, any number of times
  bool positionals = false;        ///< words not starting with '-' (and "-" itself) allowed
};

class Args {
 public:
  /// Throws UsageError for an undeclared option, a missing value or a value given twice.
  Args(const std::vector<std::string>& args, const ArgSpec& spec);

  bool Has(const std::string& name) const;
  /// The value; UsageError "NAME is required" when absent.
  const std::string& Text(const std::string& name) const;
  std::string Text(const std::string& name, const std::string& fallback) const;
  /// A finite number; UsageError naming the option otherwise.
  double Number(const std::string& name) const;
  double Number(const std::string& name, double fallback) const;
  /// A whole number >= `min`; UsageError naming the option otherwise.
  long long Integer(const std::string& name, long long fallback, long long min = 0) const;
  /// Every value of a repeated option, in the order given.
  const std::vector<std::string>& All(const std::string& name) const;
  /// The words that are not options, in order (only when the spec allows them).
  const std::vector<std::string>& Positionals() const { return positionals_; }

 private:
  std::vector<std::string> positionals_;
  std::map<std::string, std::string> values_;
  std::map<std::string, std::vector<std::string>> repeated_;
  std::set<std::string> switches_;
};

/// The whole of `text` as a finite number; UsageError naming `name` otherwise.
double ParseNumber(const std::string& name, const std::string& text);
/// Finite numbers separated by commas ("0.03,-0.01"), at least one; UsageError naming `name`.
std::vector<double> ParseNumberList(const std::string& name, const std::string& text);
/// The whole of `text` as a whole number >= `min`; UsageError naming `name` otherwise.
long long ParseInteger(const std::string& name, const std::string& text, long long min = 0);

}  // namespace mlp::base
