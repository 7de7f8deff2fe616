#pragma once
// A real PostgreSQL server (Debian's `postgresql`) for a test, in its own folder on a free local
// port: initdb with a password for the hosts' role `mlp` (scram-sha-256 over TCP), pg_ctl to
// start and stop it, and a database `mlprobe`. As root, the server runs as the `postgres` user
// (initdb refuses root). fsync is off: a test's server, not a plant's.

#include <filesystem>
#include <fstream>
#include <string>

#include "broker.h"  // FreePort, PortAccepts
#include "process_run.h"
#include <gtest/gtest.h>

namespace mlp::test {

class Postgres {
 public:
  explicit Postgres(const std::string& name)
      : dir_(std::filesystem::temp_directory_path() / ("mlp_pg_" + name)), port_(FreePort()) {
    Init();
  }
  ~Postgres() { Stop(); }

  void Init() {
    namespace fs = std::filesystem;
    if (fs::exists(dir_ / "data" / "postmaster.pid")) Ctl("-m immediate stop");
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    std::ofstream(dir_ / "pw") << kPassword << "\n";
    // libpq ignores a password file others can read: owner-only, as a plant's must be.
    std::ofstream(dir_ / "pgpass") << "*:*:*:mlp:" << kPassword << "\n";
    fs::permissions(dir_ / "pgpass", fs::perms::owner_read | fs::perms::owner_write);
    if (geteuid() == 0)
      RunProcess("chown postgres: " + dir_.string() + " " + (dir_ / "pw").string());
    const auto init = RunProcess(As() + Bin("initdb") + " -D " + (dir_ / "data").string() +
                                 " -U mlp --pwfile=" + (dir_ / "pw").string() +
                                 " --auth-host=scram-sha-256 --auth-local=trust -E UTF8");
    ASSERT_EQ(init.exit_code, 0) << init.out << init.err;
    Start();
    const auto create = RunProcess("psql '" + Uri("postgres") + "' -qc 'CREATE DATABASE mlprobe'");
    ASSERT_EQ(create.exit_code, 0) << create.err;
  }

  void Start() {
    const auto r =
        Ctl("-l " + (dir_ / "server.log").string() + " -o \"-p " + std::to_string(port_) + " -k " +
            dir_.string() + " -c listen_addresses=127.0.0.1 -c fsync=off\" -w start");
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err << ReadLog();
    running_ = true;
  }
  /// A fast shutdown: open connections are cut, as when the plant's server goes away.
  void Stop() {
    if (!running_) return;
    Ctl("-m fast -w stop");
    running_ = false;
  }
  /// The hosts' connection: the password from an owner-only passfile, never in the string.
  std::string Uri(const std::string& db = "mlprobe") const {
    return "postgresql://mlp@127.0.0.1:" + std::to_string(port_) + "/" + db +
           "?passfile=" + (dir_ / "pgpass").string() + "&connect_timeout=5";
  }
  int port() const { return port_; }
  static constexpr const char* kPassword = "pl4nt-db-secret";

 private:
  static std::string As() { return geteuid() == 0 ? "runuser -u postgres -- " : ""; }
  static std::string Bin(const std::string& program) {
    for (const auto& v : std::filesystem::directory_iterator("/usr/lib/postgresql")) {
      const auto p = v.path() / "bin" / program;
      if (std::filesystem::exists(p)) return p.string();
    }
    return program;
  }
  ProcessRun Ctl(const std::string& args) const {
    return RunProcess(As() + Bin("pg_ctl") + " -D " + (dir_ / "data").string() + " " + args +
                      " </dev/null");
  }
  std::string ReadLog() const {
    std::ifstream in(dir_ / "server.log");
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }

  std::filesystem::path dir_;
  int port_;
  bool running_ = false;
};

}  // namespace mlp::test
