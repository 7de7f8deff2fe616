#pragma once
/// @file `mlp-sim render`: frames of one capture of a scene, with their ground truth;
/// `mlp-sim serve`: a virtual probe on the network answering the host's capture requests.

#include <ostream>
#include <string>
#include <vector>

namespace mlp::sim {

/// Runs `mlp-sim <args>`; returns the exit code (probe_fw::cli::kExit*).
int RunSimCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
/// `mlp-sim serve` (args without "serve"); throws what RunSimCommand maps to exit codes.
int RunServeCommand(const std::vector<std::string>& args, std::ostream& out);

}  // namespace mlp::sim
