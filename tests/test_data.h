#pragma once
// Locating the real data from outside the project (../shared/data beside the checkout).

#include <cstdlib>
#include <filesystem>
#include <string>

namespace mlp::test {

/// The shared data folder: $MLP_SHARED_DATA (ctest sets it), else ../shared/data relative to
/// the source tree. Tests that need it fail, not skip, when it is missing.
inline std::filesystem::path SharedDataDir() {
  if (const char* env = std::getenv("MLP_SHARED_DATA"); env && *env) return env;
  return std::filesystem::path(MLP_SOURCE_DIR) / ".." / "shared" / "data";
}

}  // namespace mlp::test
