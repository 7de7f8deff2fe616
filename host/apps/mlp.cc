// mlp: the command-line client. Thin: parses the sub-command and calls the host library.

#include "mlp/host/fit_command.h"

#include <iostream>
#include <string>
#include <vector>

namespace {

constexpr const char* kUsage =
    "usage: mlp <command> [args]\n"
    "commands:\n"
    "  fit       fit a shape to a point cloud file (mlp fit --help)\n"
    "  --version print the version\n";

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty() || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage;
    return args.empty() ? mlp::host::kExitBadInput : mlp::host::kExitOk;
  }
  if (args[0] == "--version") {
    std::cout << "mlp " << MLP_VERSION << "\n";
    return mlp::host::kExitOk;
  }
  if (args[0] == "fit") {
    return mlp::host::RunFitCommand({args.begin() + 1, args.end()}, std::cout, std::cerr);
  }
  std::cerr << "mlp: unknown command '" << args[0] << "'\n" << kUsage;
  return mlp::host::kExitBadInput;
}
