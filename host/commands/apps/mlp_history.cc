// mlp-history: the job history, a host's file or the plant's database (run by `mlp history`).
// Its own program: it loads libpq and SQLite, which the macro's `mlp` does without. Thin.

#include "mlp/host/history_command.h"

#include <iostream>

int main(int argc, char** argv) {
  return mlp::host::RunHistoryCommand({argv + 1, argv + argc}, std::cout, std::cerr);
}
