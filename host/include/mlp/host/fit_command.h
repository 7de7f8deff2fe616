#pragma once
/// @file `mlp fit`: fit a shape to a cloud file and print one JSON object (the contract other
/// checks rely on; field names in docs/CLI.md).

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes of the command-line tools.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,  ///< a bug: please report
  kExitBadInput = 2,  ///< unusable arguments, file or points; nothing was written on stdout
};

/// Runs `mlp fit ARGS...` (args exclude "fit"); JSON on `out`, one-line reasons on `err`.
int RunFitCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// Usage text of `mlp fit`.
std::string FitUsage();

}  // namespace mlp::host
