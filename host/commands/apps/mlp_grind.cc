// mlp-grind: profile error during curve grinding (run by `mlp grind`). Thin.

#include "mlp/host/grind_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunGrindCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
