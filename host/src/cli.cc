#include "mlp/host/cli.h"

#include <cmath>
#include <cstdlib>
#include <system_error>

namespace mlp::host {

double ParseNumber(const std::string& flag, const std::string& value) {
  char* end = nullptr;
  const double v = std::strtod(value.c_str(), &end);
  if (value.empty() || *end != '\0' || !std::isfinite(v)) {
    throw UsageError(flag + " needs a number, got '" + value + "'");
  }
  return v;
}

std::filesystem::path ProgramDir() {
  std::error_code ec;
  return std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
}

std::filesystem::path DefaultSamplesDir() {
  const std::filesystem::path beside = ProgramDir() / "../../samples";
  return std::filesystem::exists(beside) ? beside : std::filesystem::path("samples");
}

}  // namespace mlp::host
