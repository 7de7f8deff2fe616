#pragma once
/// @file The macro-facing side of `mlp`: talk to mlp-hostd over its job socket (docs/HOSTD.md).
///   mlp status  [--socket PATH] [--json]           the service's health: probes, machines
///   mlp request [--socket PATH] [--timeout S] FILE  send a request (a JSON file, - for stdin)
/// The socket is --socket, else $MLP_SOCKET, else /run/mlprobe/jobs.sock.

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

/// Exit codes of job commands beyond kExitOk / kExitInternal / kExitBadInput (cli.h).
enum JobExit : int {
  kExitOutOfTolerance = 5,  ///< measured, decided, outside the tolerance
  kExitRefused = 6,         ///< the job would write but a plausibility or safety check refused
  kExitJobFailed = 7,       ///< the job could not be done: host down, probe unreachable, ...
};

/// `mlp status ...` / `mlp request ...` (args exclude the command word).
int RunStatusCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int RunRequestCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
