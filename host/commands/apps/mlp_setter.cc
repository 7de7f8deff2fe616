// mlp-setter: the laser tool setter's beam signal (run by `mlp setter`). Thin.

#include "mlp/host/setter_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunSetterCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
