#pragma once
// Running the project's programs as real processes in tests: stdout and stderr captured apart.

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <sys/wait.h>
#include <unistd.h>

namespace mlp::test {

struct ProcessRun {
  int exit_code = -1;  ///< -1: killed by a signal
  std::string out, err;
};

/// Runs `command` with /bin/sh; stderr goes through a temporary file (a second pipe would need
/// a poll loop to avoid dead-locking on a full buffer).
inline ProcessRun RunProcess(const std::string& command) {
  static std::atomic<int> counter{0};  // tests run processes from several threads at once
  const std::filesystem::path err_file =
      std::filesystem::temp_directory_path() /
      ("mlp_test_stderr_" + std::to_string(getpid()) + "_" + std::to_string(counter++));
  FILE* pipe = popen((command + " 2>" + err_file.string()).c_str(), "r");
  ProcessRun r;
  if (pipe == nullptr) return r;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof(buf), pipe)) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream e(err_file);
  r.err.assign(std::istreambuf_iterator<char>(e), std::istreambuf_iterator<char>());
  std::filesystem::remove(err_file);
  return r;
}

}  // namespace mlp::test
