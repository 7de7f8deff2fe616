#pragma once
/// @file What the host's command-line tools share: exit codes and the error for unusable
/// arguments.

#include <stdexcept>

namespace mlp::host {

/// Exit codes of the command-line tools.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,  ///< a bug: please report
  kExitBadInput = 2,  ///< unusable arguments, file or points; nothing was written on stdout
};

/// Unusable arguments: the tool prints the reason and its usage, and exits kExitBadInput.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mlp::host
