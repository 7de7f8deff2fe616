#pragma once
// A real Mosquitto broker (Debian's `mosquitto`) for a test, in its own folder on free local
// ports: users from a password file (mosquitto_passwd), a plain listener and a TLS one whose
// certificates the openssl command makes for the test (a CA and the broker's certificate for
// 127.0.0.1), persistence so that a restart keeps sessions. And a subscriber, through
// libmosquitto, that records what arrives.

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "child_process.h"
#include "process_run.h"
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <mosquitto.h>
#include <netinet/in.h>
#include <nlohmann/json.hpp>
#include <sys/socket.h>

namespace mlp::test {

/// A local TCP port that was free a moment ago (the kernel's pick for port 0).
inline int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  socklen_t n = sizeof(a);
  const bool ok = bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0 &&
                  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n) == 0;
  close(fd);
  return ok ? ntohs(a.sin_port) : -1;
}

inline bool PortAccepts(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof(a)) == 0;
  close(fd);
  return ok;
}

/// Polls `ok` every 20 ms for up to `limit` (generous: a loaded machine is slow, not wrong).
template <typename F>
bool Eventually(F ok, std::chrono::milliseconds limit = std::chrono::seconds(60)) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (ok()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return ok();
}

struct BrokerUser {
  std::string name, password;
};

class Broker {
 public:
  Broker(const std::string& name, std::vector<BrokerUser> users)
      : dir_(std::filesystem::temp_directory_path() / ("mlp_broker_" + name)),
        port_(FreePort()),
        tls_port_(FreePort()) {
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    for (const auto& u : users) {
      const auto run = RunProcess(std::string("mosquitto_passwd ") + (users_ ? "" : "-c ") + "-b " +
                                  (dir_ / "passwd").string() + " " + u.name + " " + u.password);
      EXPECT_EQ(run.exit_code, 0) << run.err;
      users_ = true;
    }
    MakeCertificates(dir_, "ca", "broker");
    std::ofstream conf(dir_ / "mosquitto.conf");
    if (geteuid() == 0)
      conf << "user root\n";  // else it would drop to `mosquitto` and not read dir
    conf << "persistence true\npersistence_location " << dir_.string() << "/\n"
         << "log_dest file " << (dir_ / "broker.log").string() << "\n"
         << "log_type all\n"
         << "allow_anonymous false\npassword_file " << (dir_ / "passwd").string() << "\n"
         << "listener " << port_ << " 127.0.0.1\n"
         << "listener " << tls_port_ << " 127.0.0.1\n"
         << "cafile " << (dir_ / "ca.crt").string() << "\n"
         << "certfile " << (dir_ / "broker.crt").string() << "\n"
         << "keyfile " << (dir_ / "broker.key").string() << "\n";
    conf.close();
    Start();
  }
  ~Broker() { Stop(); }

  /// A CA (`<ca>.crt`, `.key`) and a certificate of it for 127.0.0.1 (`<leaf>.crt`, `.key`),
  /// P-256 keys, valid two days.
  static void MakeCertificates(const std::filesystem::path& dir,
                               const std::string& ca,
                               const std::string& leaf) {
    const std::string d = dir.string() + "/";
    const std::string key = " -newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes ";
    const auto run =
        RunProcess("(cd " + d + " && openssl req -x509" + key + "-keyout " + ca + ".key -out " +
                   ca + ".crt -days 2 -subj /CN=" + ca + " && openssl req" + key + "-keyout " +
                   leaf + ".key -out " + leaf +
                   ".csr -subj /CN=127.0.0.1 && printf "
                   "'subjectAltName=IP:127.0.0.1,DNS:localhost' > " +
                   leaf +
                   ".ext && openssl x509 -req "
                   "-in " +
                   leaf + ".csr -CA " + ca + ".crt -CAkey " + ca + ".key -CAcreateserial -out " +
                   leaf + ".crt -days 2 -extfile " + leaf + ".ext)");
    ASSERT_EQ(run.exit_code, 0) << run.err;
  }

  void Start() {
    broker_ = std::make_unique<Child>(
        std::vector<std::string>{"/usr/sbin/mosquitto", "-c", (dir_ / "mosquitto.conf").string()},
        dir_ / "stderr.log");
    // Fails at once when the broker exits (a bad configuration), not after the wait.
    ASSERT_TRUE(Eventually(
        [&] { return !broker_->Alive() || (PortAccepts(port_) && PortAccepts(tls_port_)); }));
    ASSERT_TRUE(broker_->Alive()) << "mosquitto did not start; see " << dir_ / "broker.log";
  }
  /// SIGTERM: the broker saves its sessions and queued messages, then exits.
  void Stop() { broker_.reset(); }

  int port() const { return port_; }
  int tls_port() const { return tls_port_; }
  std::string ca_file() const { return (dir_ / "ca.crt").string(); }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
  int port_, tls_port_;
  bool users_ = false;
  std::unique_ptr<Child> broker_;
};

struct Message {
  std::string topic;
  nlohmann::json payload;
  bool retained = false;
};

/// A client that subscribes to `filter` with QoS 1 and keeps what arrives; with a fixed id and
/// `persistent`, the broker keeps its session (and messages for it) while it is away.
class Subscriber {
 public:
  Subscriber(const Broker& broker,
             const BrokerUser& user,
             const std::string& filter,
             const std::string& id,
             bool persistent = false)
      : filter_(filter) {
    mosquitto_lib_init();
    client_ = mosquitto_new(id.c_str(), !persistent, this);
    mosquitto_int_option(client_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V311);
    mosquitto_username_pw_set(client_, user.name.c_str(), user.password.c_str());
    mosquitto_connect_callback_set(client_, [](mosquitto* c, void* self, int rc) {
      if (rc == 0)
        mosquitto_subscribe(c, nullptr, static_cast<Subscriber*>(self)->filter_.c_str(), 1);
    });
    mosquitto_subscribe_callback_set(client_, [](mosquitto*, void* self, int, int, const int*) {
      static_cast<Subscriber*>(self)->subscribed_ = true;
    });
    mosquitto_message_callback_set(client_, [](mosquitto*, void* self, const mosquitto_message* m) {
      auto& s = *static_cast<Subscriber*>(self);
      Message msg{m->topic,
                  nlohmann::json::parse(static_cast<const char*>(m->payload),
                                        static_cast<const char*>(m->payload) + m->payloadlen,
                                        nullptr, false),
                  m->retain};
      std::lock_guard lock(s.m_);
      s.messages_.push_back(msg);
    });
    mosquitto_reconnect_delay_set(client_, 1, 1, false);
    mosquitto_connect_async(client_, "127.0.0.1", broker.port(), 30);
    mosquitto_loop_start(client_);
    EXPECT_TRUE(Eventually([&] { return subscribed_.load(); })) << "subscriber " << id;
  }
  ~Subscriber() {
    mosquitto_disconnect(client_);
    mosquitto_loop_stop(client_, false);
    mosquitto_destroy(client_);
  }
  std::vector<Message> Messages() const {
    std::lock_guard lock(m_);
    return messages_;
  }
  /// The messages on `topic` once at least `count` arrived (or what came within a minute).
  std::vector<Message> On(const std::string& topic, std::size_t count = 1) const {
    std::vector<Message> found;
    Eventually([&] {
      found.clear();
      for (const Message& m : Messages())
        if (m.topic == topic) found.push_back(m);
      return found.size() >= count;
    });
    return found;
  }

 private:
  std::string filter_;
  mosquitto* client_ = nullptr;
  std::atomic<bool> subscribed_{false};
  mutable std::mutex m_;
  std::vector<Message> messages_;
};

}  // namespace mlp::test
