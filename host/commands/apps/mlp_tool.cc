// mlp-tool: tools from their shadow images (run by `mlp tool`). Thin.

#include "mlp/host/tool_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunToolCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
