// mlp-kinematics: a five-axis trunnion checked from sphere centres (run by `mlp kinematics`).
// Thin.

#include "mlp/host/kinematics_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunKinematicsCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
