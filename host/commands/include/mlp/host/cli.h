#pragma once
/// @file What the host's command-line tools share: the argument parser and exit codes (base's),
/// input and output files, and where the programs and the samples are.

#include "mlp/base/args.h"
#include "mlp/base/format.h"

#include <filesystem>
#include <iomanip>
#include <sstream>
#include <string>

namespace mlp::host {

// The exit codes, the error for unusable arguments and the one argument parser are base's,
// shared with the probe's programs.
using base::Args;
using base::ArgSpec;
using base::ExitCode;
using base::kExitBadInput;
using base::kExitInternal;
using base::kExitOk;
using base::ParseInteger;
using base::ParseNumber;
using base::UsageError;

/// A number with a fixed count of decimals, for the tools' readable summaries and pictures.
using base::Fixed;

/// A HAL component's name (its pins' prefix): 1..40 of a-z 0-9 - _; UsageError otherwise.
std::string HalComponentName(const std::string& name);

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
