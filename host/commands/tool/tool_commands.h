#pragma once
// `mlp tool`'s sub-commands, shared between its source files (not installed).

#include <ostream>
#include <string>
#include <vector>

namespace mlp::host::tool {

/// `mlp tool measure ...` and `mlp tool calibrate ...` (tool_measure_command.cc).
int Measure(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int Calibrate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
/// `mlp tool render-texture ...` and `mlp tool relocate ...` (tool_relocate_command.cc).
int RenderTexture(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int Relocate(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
/// `mlp tool gauge-setup ...` and `mlp tool gauge ...` (tool_gauge_command.cc).
int GaugeSetup(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int GaugeOne(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host::tool
