// mlp-fw: the probe firmware's command line (thin: the work is in the probe_fw library).

#include <iostream>

#include "fw_command.h"

int main(int argc, char** argv) {
  return mlp::probe_fw::RunFwCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
