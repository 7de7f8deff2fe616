#include "mlp/host/cli.h"

#include "mlp/base/files.h"

#include <cmath>
#include <cstdlib>
#include <system_error>

namespace mlp::host {

std::string HalComponentName(const std::string& name) {
  if (name.empty() || name.size() > 40 ||
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789-_") != std::string::npos)
    throw UsageError("--name: 1..40 of a-z 0-9 - _ (a HAL name)");
  return name;
}

std::string ReadInputFile(const std::string& path) {
  try {
    return base::ReadFile(path);
  } catch (const base::FileError& e) {
    throw UsageError(e.what());
  }
}

void WriteOutputFile(const std::string& path, const std::string& text) {
  try {
    base::WriteFileAtomically(path, text);
  } catch (const base::FileError& e) {
    throw UsageError(e.what());
  }
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
