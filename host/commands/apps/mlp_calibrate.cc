// mlp-calibrate: calibration from captures on disk (run by `mlp calibrate`). Thin.

#include "mlp/host/calibrate_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunCalibrateCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
