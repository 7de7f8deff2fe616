// mlp-demo: the whole job on the virtual machine (`mlp demo` runs it). Thin: see
// mlp/host/demo_command.h.

#include "mlp/host/demo_command.h"

#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  return mlp::host::RunDemoCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
