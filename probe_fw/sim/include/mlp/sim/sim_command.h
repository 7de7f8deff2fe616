#pragma once
/// @file `mlp-sim render`: frames of one capture of a scene, with their ground truth.

#include <ostream>
#include <string>
#include <vector>

namespace mlp::sim {

/// Runs `mlp-sim <args>`; returns the exit code (probe_fw::cli::kExit*).
int RunSimCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::sim
