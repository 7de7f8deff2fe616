#pragma once
/// @file `mlp-fw run`: frames (a capture directory or the board's camera) -> ROI -> stripe
/// centres -> triangulation -> PLY cloud in the probe frame; `mlp-fw stripes` (calibration);
/// `mlp-fw serve`: the probe on the link. docs/CLI.md has the contract. Programs only.

#include <ostream>
#include <string>
#include <vector>

namespace mlp::probe_fw {

/// Runs `mlp-fw <args>`; returns the exit code (cli::kExit*).
int RunFwCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::probe_fw
