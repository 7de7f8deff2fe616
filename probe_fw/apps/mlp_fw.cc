// mlp-fw: the probe firmware's command line (thin: the work is in the probe_fw library).

#include "mlp/probe_fw/fw_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::probe_fw::RunFwCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
