// mlp-verify: the probe's acceptance test on the virtual machine (`mlp verify` runs it). Thin:
// see mlp/host/verify_command.h.

#include "mlp/host/verify_command.h"

#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  return mlp::host::RunVerifyCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
