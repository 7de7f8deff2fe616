#pragma once
// Locating the real data from outside the project: the sets whose licences allow it are in the
// repository (samples/data); the rest stays in the shared folder beside the checkout.

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace mlp::test {

/// The checkout the tests were built from (tests/test_paths.cc).
std::string SourceDir();

/// A program of this build by its file name ("mlp", "mlp-hostd", "mlp-sim", "mlp-fw").
std::string Program(const std::string& name);

/// The real data kept in the repository (samples/data: PCL clouds, NIST, the line scanner).
inline std::filesystem::path RepoDataDir() {
  return std::filesystem::path(SourceDir()) / "samples" / "data";
}

/// The shared data folder (only the Blaser images, which may not be copied into the repository):
/// $MLP_SHARED_DATA (ctest sets it), else ../shared/data relative to the source tree. Tests that
/// need it fail, not skip, when it is missing.
inline std::filesystem::path SharedDataDir() {
  if (const char* env = std::getenv("MLP_SHARED_DATA"); env && *env) return env;
  return std::filesystem::path(SourceDir()) / ".." / "shared" / "data";
}

/// How much slower than the release build this build runs the same work: $MLP_TEST_TIME_SCALE
/// (scripts/sanitize.sh sets 4 for its ASan + UBSan build), else 1. Only the waits that give normal
/// work time to finish scale with it, never a limit a test asserts.
inline double TimeScale() {
  const char* env = std::getenv("MLP_TEST_TIME_SCALE");
  const double scale = env && *env ? std::strtod(env, nullptr) : 1.0;
  return scale >= 1.0 ? scale : 1.0;
}

/// A text file whole ("" when it cannot be read: the caller's assertion says what).
inline std::string ReadText(const std::filesystem::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace mlp::test
