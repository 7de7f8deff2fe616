#pragma once
/// @file Command-line plumbing of the probe programs (mlp-fw, mlp-sim; linked into programs
/// only, never into a library). Options are parsed by base::Args, the parser of every program;
/// the exit codes are those they share with `mlp` (docs/CLI.md) and the camera's.

#include "mlp/base/args.h"
#include "mlp/probe_fw/frame.h"

#include <string>

namespace mlp::probe_fw::cli {

using base::kExitBadInput;  // bad arguments or input files; nothing was written
using base::kExitOk;
using base::UsageError;
constexpr int kExitFailure = base::kExitInternal;  ///< an internal error (a bug): report it
constexpr int kExitNoDevice = 3;                   ///< the camera is missing or failed

/// "x0,y0,width,height" in sensor pixels (probe_fw::ParseAoi, its RoiError as UsageError).
Aoi ParseAoi(const std::string& text);

}  // namespace mlp::probe_fw::cli
