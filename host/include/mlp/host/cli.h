#pragma once
/// @file What the host's command-line tools share: exit codes, the error for unusable
/// arguments, reading a number argument, and where the programs and the samples are.

#include <filesystem>
#include <stdexcept>
#include <string>

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

/// A finite number, the whole of `value`; otherwise UsageError naming `flag`.
double ParseNumber(const std::string& flag, const std::string& value);

/// A file named on the command line, whole; UsageError (exit kExitBadInput) when unreadable.
std::string ReadInputFile(const std::string& path);

/// A tool's output file, whole or not at all (base::WriteFileAtomically); UsageError when it
/// cannot be written.
void WriteOutputFile(const std::string& path, const std::string& text);

/// The folder of the running program (its siblings: mlp-hostd, mlp-sim, ...).
std::filesystem::path ProgramDir();

/// The samples folder: ../../samples from the program (a build tree in the checkout), else
/// ./samples.
std::filesystem::path DefaultSamplesDir();

}  // namespace mlp::host
