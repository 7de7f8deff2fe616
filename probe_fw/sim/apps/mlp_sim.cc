// mlp-sim: the virtual probe's command line (thin: the work is in the sim library).

#include <iostream>

#include "sim_command.h"

int main(int argc, char** argv) {
  return mlp::sim::RunSimCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
