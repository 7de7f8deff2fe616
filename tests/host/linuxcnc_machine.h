#pragma once
// A headless LinuxCNC (Debian linuxcnc-uspace) on a copy of a sample config, for the
// controller tests: started with the environment ../shared/LINUXCNC.md lists, driven through
// tests/linuxcnc/lcnc.py (its Python module), stopped through its display.

#include <chrono>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include "process_run.h"
#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp::test {

inline const std::string kLinuxCncDriver = mlp::test::SourceDir() + "/tests/linuxcnc/lcnc.py";

/// A copy of the sample machine (samples/linuxcnc/mlprobe-sim) in the temporary folder under
/// `name`, its INI with `halfile` loaded after orient_sim.hal and HAL_PIN_VARS on: the two
/// lines SETTER.md and GRIND.md ask a machine's INI for.
inline std::filesystem::path SampleConfigWith(const std::string& name, const std::string& halfile) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::copy(SourceDir() + "/samples/linuxcnc/mlprobe-sim", dir, fs::copy_options::recursive);
  std::string ini = ReadText(dir / "mlprobe-sim.ini");
  ini = std::regex_replace(ini, std::regex("HALFILE = orient_sim.hal\n"),
                           "HALFILE = orient_sim.hal\nHALFILE = " + halfile + "\n");
  ini = std::regex_replace(ini, std::regex("\\[RS274NGC\\]\n"), "[RS274NGC]\nHAL_PIN_VARS = 1\n");
  std::ofstream(dir / "mlprobe-sim.ini") << ini;
  return dir;
}

class LinuxCnc {
 public:
  /// `env` adds variables for LinuxCNC and the programs it starts ("NAME=value ...").
  LinuxCnc(const std::filesystem::path& config, const std::string& ini, const std::string& env = "")
      : config_(config) {
    namespace fs = std::filesystem;
    using namespace std::chrono_literals;
    fs::create_directories(config / "home");
    fs::create_directories(config / "rtapi");
    fs::permissions(config / "rtapi", fs::perms::all | fs::perms::sticky_bit);
    env_ = "HOME=" + (config / "home").string() +
           " RTAPI_UID=1000 RTAPI_FIFO_PATH=" + (config / "rtapi" / "fifo").string() + " " + env;
    std::system(("cd " + config.string() + " && env " + env_ + " setsid linuxcnc -r " + ini +
                 " > linuxcnc.log 2>&1 &")
                    .c_str());
    // Up when the tool table's shared map exists: 1-3 s idle; a busy machine gets a minute.
    for (int i = 0; i < 1200 && !fs::exists(config / "home" / ".tool.mmap"); ++i)
      std::this_thread::sleep_for(50ms);
  }
  ~LinuxCnc() {
    using namespace std::chrono_literals;
    std::ofstream(config_ / "display.stop") << "";
    // LinuxCNC cleans up once its display exits: wait so the next test can start one.
    for (int i = 0; i < 1200 && RunProcess("pgrep -x milltask").exit_code == 0; ++i)
      std::this_thread::sleep_for(50ms);
  }
  LinuxCnc(const LinuxCnc&) = delete;
  LinuxCnc& operator=(const LinuxCnc&) = delete;

  bool Up() const { return std::filesystem::exists(config_ / "home" / ".tool.mmap"); }
  /// Waits (a minute at most) until `pin` exists: the machine's .tool.mmap comes before its
  /// HAL files have loaded their user-space components.
  bool WaitForPin(const std::string& pin) const {
    using namespace std::chrono_literals;
    for (int i = 0; i < 1200; ++i) {
      if (Hal("getp " + pin).exit_code == 0) return true;
      std::this_thread::sleep_for(50ms);
    }
    return false;
  }
  /// halcmd on the running machine (as the M-codes call it).
  ProcessRun Hal(const std::string& args) const {
    return RunProcess("env " + env_ + " halcmd " + args);
  }
  /// Runs `program` to its end; the driver's JSON (errors, tool table, offsets, position).
  nlohmann::json Run(const std::string& program) const {
    const std::filesystem::path p = config_ / "program.ngc";
    std::ofstream(p) << program;
    const auto r = RunProcess("env " + env_ + " /usr/bin/python3 " + kLinuxCncDriver + " run " +
                              p.string() + " 120");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
  }
  /// The live state without running anything.
  nlohmann::json State() const {
    const auto r = RunProcess("env " + env_ + " /usr/bin/python3 " + kLinuxCncDriver + " state");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r.exit_code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
  }

 private:
  std::filesystem::path config_;
  std::string env_;
};

}  // namespace mlp::test
