#pragma once
// A program the test starts and stops (a service, a broker, a database server), its stderr in a
// file.

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

namespace mlp::test {

// A child process with its stderr in a file; SIGTERM and wait on destruction.
class Child {
 public:
  /// `in_child`: run in the child before exec (e.g. to lower its resource limits).
  Child(const std::vector<std::string>& argv,
        const std::filesystem::path& log,
        const std::function<void()>& in_child = {}) {
    pid_ = fork();
    if (pid_ == 0) {
      std::freopen(log.c_str(), "w", stderr);
      if (in_child) in_child();
      std::vector<char*> a;
      for (const auto& s : argv) a.push_back(const_cast<char*>(s.c_str()));
      a.push_back(nullptr);
      execv(a[0], a.data());
      _exit(127);
    }
  }
  ~Child() { Stop(); }
  pid_t Pid() const { return pid_; }
  /// The process's peak resident memory so far [MB] (VmHWM); 0 when it has none to read.
  double PeakMemoryMb() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
    for (std::string line; std::getline(in, line);)
      if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
    return 0.0;
  }
  /// True while the process runs (not exited, not killed).
  /// Does not reap it: Stop still reads its exit code.
  bool Alive() const {
    if (pid_ <= 0) return false;
    siginfo_t info{};
    return waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
           info.si_pid == 0;
  }
  /// SIGTERM (graceful) by default; SIGKILL is a crash.
  int Stop(int signal = SIGTERM) {
    if (pid_ <= 0) return exit_code_;
    kill(pid_, signal);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return exit_code_;
  }

 private:
  pid_t pid_ = -1;
  int exit_code_ = -1;
};

}  // namespace mlp::test
