#pragma once
/// @file `mlp fit`: fit a shape to a cloud file and print one JSON object (the contract other
/// checks rely on; field names in docs/CLI.md).

#include "mlp/host/cli.h"

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// Runs `mlp fit ARGS...` (args exclude "fit"); JSON on `out`, one-line reasons on `err`.
int RunFitCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/// Usage text of `mlp fit`.
std::string FitUsage();

}  // namespace mlp::host
