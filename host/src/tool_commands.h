#pragma once
// `mlp tool`'s sub-commands, shared between its source files (not installed).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host::tool {

/// `flag`'s value as a finite number; throws UsageError naming the flag.
double Number(const std::string& flag, const std::string& value);

/// `mlp tool measure ...` and `mlp tool calibrate ...` (tool_measure_command.cc).
int Measure(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int Calibrate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host::tool
