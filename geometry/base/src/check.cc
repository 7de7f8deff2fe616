#include "mlp/base/check.h"

namespace mlp::base {

void FailCheck(const char* file, int line, const char* expression, const std::string& detail) {
  std::string what =
      std::string(file) + ":" + std::to_string(line) + ": check failed: " + expression;
  if (!detail.empty()) what += " (" + detail + ")";
  throw CheckFailure(what);
}

}  // namespace mlp::base
