// mlp: the command-line client. Thin: parses the sub-command and calls the host library.

#include "mlp/host/fit_command.h"
#include "mlp/host/job_command.h"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <unistd.h>

namespace {

constexpr const char* kUsage =
    "usage: mlp <command> [args]\n"
    "commands:\n"
    "  fit       fit a shape to a point cloud file (mlp fit --help)\n"
    "  calibrate sphere hand-eye, quick re-calibration, calibration records\n"
    "            (mlp calibrate --help; runs mlp-calibrate beside this program)\n"
    "  demo      the whole job on the virtual machine (runs mlp-demo beside this program)\n"
    "  verify    the probe's acceptance test (ISO 10360-8 manner) on the virtual machine\n"
    "            (mlp verify --help; runs mlp-verify beside this program)\n"
    "  status    the host service's health: probes, machines (mlp-hostd must run)\n"
    "  request   send a job request (JSON) to mlp-hostd and print its reply\n"
    "  history   list or export the job history (mlp history --help)\n"
    "  tool      tools from their shadow images: strobe plan, virtual camera, measurement\n"
    "            (mlp tool --help; runs mlp-tool beside this program)\n"
    "  setter    the laser tool setter's beam signal: virtual signal, calibration, trigger\n"
    "            (mlp setter --help; runs mlp-setter beside this program)\n"
    "  grind     profile error while grinding, from back-lit frames: compensation vectors\n"
    "            (mlp grind --help; runs mlp-grind beside this program)\n"
    "  kinematics a five-axis trunnion's rotary axes checked from sphere centres\n"
    "            (mlp kinematics --help; runs mlp-kinematics beside this program)\n"
    "  --version print the version\n";

// Replaces this process with `name` from the same folder (mlp-calibrate links Ceres and OpenCV,
// mlp-demo the simulator: `mlp` itself loads neither).
int RunSibling(char** argv, const char* name) {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const std::string program = (ec ? std::filesystem::path(argv[0]) : self).parent_path() / name;
  argv[1] = const_cast<char*>(name);
  execv(program.c_str(), argv + 1);
  std::cerr << "mlp: cannot run " << program << ": " << std::strerror(errno) << "\n";
  return mlp::host::kExitInternal;
}

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
  if (args[0] == "calibrate") return RunSibling(argv, "mlp-calibrate");
  if (args[0] == "demo") return RunSibling(argv, "mlp-demo");
  if (args[0] == "verify") return RunSibling(argv, "mlp-verify");
  if (args[0] == "tool") return RunSibling(argv, "mlp-tool");
  if (args[0] == "setter") return RunSibling(argv, "mlp-setter");
  if (args[0] == "grind") return RunSibling(argv, "mlp-grind");
  if (args[0] == "kinematics") return RunSibling(argv, "mlp-kinematics");
  if (args[0] == "fit") {
    return mlp::host::RunFitCommand({args.begin() + 1, args.end()}, std::cout, std::cerr);
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  if (args[0] == "status") return mlp::host::RunStatusCommand(rest, std::cout, std::cerr);
  if (args[0] == "request") return mlp::host::RunRequestCommand(rest, std::cout, std::cerr);
  if (args[0] == "history") return RunSibling(argv, "mlp-history");
  std::cerr << "mlp: unknown command '" << args[0] << "'\n" << kUsage;
  return mlp::host::kExitBadInput;
}
