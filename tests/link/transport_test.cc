// The link over real loopback sockets: a fault-injecting relay that cuts, truncates and corrupts
// the byte stream; hostile peers; several probes at once. Bounded in time by the waits below.

#include "mlp/link/transport.h"

#include <atomic>
#include <map>
#include <mutex>
#include <random>
#include <thread>
#include <utility>  // before Asio (Boost 1.74's awaitable.hpp needs std::exchange)

#include "link_test_util.h"
#include <boost/asio.hpp>
#include <gtest/gtest.h>

namespace mlp::link {
namespace {

using namespace testing;

namespace asio = boost::asio;
using asio::ip::tcp;
using namespace std::chrono_literals;

constexpr auto kDeliveryTimeout = 60s;

LinkCloud MakeCloud(const std::string& serial, int index, std::mt19937* gen) {
  std::uniform_real_distribution<double> coord(-50.0, 150.0);
  LinkCloud c;
  c.capture_id = serial + "-" + std::to_string(index);
  c.probe_serial = serial;
  c.calibration_id = "cal-1";
  c.mcs_from_flange.translation().x() = index;
  const int n = 50 + static_cast<int>((*gen)() % 300);
  for (int i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) c.xyz.push_back(coord(*gen));
    c.quality.push_back(static_cast<float>((*gen)() % 256) / 255.0f);
  }
  return c;
}

// Receives clouds on the host and remembers each delivery.
struct Inbox : LogBook {
  // m (LogBook's) guards everything here
  std::map<std::string, LinkCloud> clouds;
  int delivered_twice = 0;
  void Take(const LinkCloud& c) {
    std::lock_guard lock(m);
    if (!clouds.emplace(c.capture_id, c).second) ++delivered_twice;
  }
};

// A TCP relay between probe and host that cuts connections, truncates and corrupts bytes, in
// both directions, with a fixed seed.
class FaultRelay {
 public:
  FaultRelay(std::uint16_t target, unsigned seed)
      : target_(target),
        acceptor_(io_, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0)),
        gen_(seed) {
    Accept();
    thread_ = std::thread([this] { io_.run(); });
  }
  ~FaultRelay() {
    io_.stop();
    thread_.join();
  }
  std::uint16_t Port() const { return acceptor_.local_endpoint().port(); }
  int faults() const { return faults_; }

 private:
  struct Pair {
    Pair(asio::io_context& io) : a(io), b(io) {}
    tcp::socket a, b;
    std::array<std::uint8_t, 4096> buf_ab{}, buf_ba{};
    void Close() {
      boost::system::error_code ec;
      a.close(ec), b.close(ec);
    }
  };

  void Accept() {
    auto p = std::make_shared<Pair>(io_);
    acceptor_.async_accept(p->a, [this, p](boost::system::error_code ec) {
      if (ec) return;
      p->b.async_connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), target_),
                         [this, p](boost::system::error_code ec2) {
                           if (ec2) return p->Close();
                           Pump(p, &p->a, &p->b, &p->buf_ab);
                           Pump(p, &p->b, &p->a, &p->buf_ba);
                         });
      Accept();
    });
  }

  void Pump(std::shared_ptr<Pair> p,
            tcp::socket* from,
            tcp::socket* to,
            std::array<std::uint8_t, 4096>* buf) {
    from->async_read_some(
        asio::buffer(*buf), [=, this](boost::system::error_code ec, std::size_t n) {
          if (ec) return p->Close();
          // Per chunk read (up to 4 KB, a few clouds): 3 % cut, 3 % one corrupted byte, 2 %
          // truncated then cut.
          const auto roll = static_cast<unsigned>(gen_() % 1000);
          if (roll < 30) {  // cut
            ++faults_;
            return p->Close();
          }
          if (roll < 60) {  // corrupt one byte
            ++faults_;
            (*buf)[gen_() % n] ^= static_cast<std::uint8_t>(1 + gen_() % 255);
          }
          bool close_after = false;
          if (roll >= 60 && roll < 80 && n > 1) {  // truncate, then cut
            ++faults_;
            n = 1 + gen_() % (n - 1);
            close_after = true;
          }
          asio::async_write(*to, asio::buffer(buf->data(), n),
                            [=, this](boost::system::error_code ec2, std::size_t) {
                              if (ec2 || close_after) return p->Close();
                              Pump(p, from, to, buf);
                            });
        });
  }

  std::uint16_t target_;
  asio::io_context io_;
  tcp::acceptor acceptor_;
  std::mt19937 gen_;
  std::thread thread_;
  std::atomic<int> faults_{0};
};

// Submits, waiting while the store-and-forward buffer is full.
void SubmitAll(ProbeLink& probe, const std::vector<LinkCloud>& clouds) {
  for (const LinkCloud& c : clouds) {
    while (probe.Submit(c) == SubmitResult::kBufferFull) std::this_thread::sleep_for(1ms);
  }
}

TEST(Transport, ThousandCloudsThroughAFaultyRelayArriveExactlyOnceAndIntact) {
  Inbox inbox;
  HostLink host(
      HostConfig({{"P-1", KeyOf(1)}}), [&](const LinkCloud& c) { inbox.Take(c); },
      [&](const std::string& l) {
        if (getenv("MLP_LINK_DEBUG")) fprintf(stderr, "host %s\n", l.c_str());
        inbox.Log(l);
      });
  host.Start();
  FaultRelay relay(host.Port(), 11);
  ProbeLink probe(ProbeConfig("P-1", KeyOf(1), relay.Port()), [](const std::string& l) {
    if (getenv("MLP_LINK_DEBUG")) fprintf(stderr, "probe %s\n", l.c_str());
  });
  probe.Start();
  std::mt19937 gen(5);
  std::vector<LinkCloud> sent;
  for (int i = 0; i < 1000; ++i) sent.push_back(MakeCloud("P-1", i, &gen));
  SubmitAll(probe, sent);
  ASSERT_TRUE(probe.WaitAllAcknowledged(kDeliveryTimeout)) << probe.Unacknowledged() << " left";
  probe.Stop();
  host.Stop();
  std::lock_guard lock(inbox.m);
  EXPECT_EQ(inbox.delivered_twice, 0);
  ASSERT_EQ(inbox.clouds.size(), 1000u);
  for (const LinkCloud& c : sent) {
    const LinkCloud expected = Quantised(c);
    const LinkCloud& got = inbox.clouds.at(c.capture_id);
    ASSERT_EQ(got.xyz, expected.xyz) << c.capture_id;  // bit-exact after decoding
    ASSERT_EQ(got.quality, expected.quality);
    ASSERT_TRUE(got.mcs_from_flange.matrix() == expected.mcs_from_flange.matrix());
  }
  const auto stats = host.Stats();
  std::printf("relay faults %d, probe reconnects %llu, host rejected %llu, duplicates %llu\n",
              relay.faults(), static_cast<unsigned long long>(probe.Reconnects()),
              static_cast<unsigned long long>(stats.rejected),
              static_cast<unsigned long long>(stats.duplicates));
  EXPECT_GT(relay.faults(), 50);   // the relay really did its job
  EXPECT_GT(stats.rejected, 10u);  // and corrupted frames were caught, not delivered
  EXPECT_EQ(stats.delivered, 1000u);
}

// Sends raw bytes to the host and reads until it closes the connection.
void SendRaw(std::uint16_t port, const Bytes& bytes) {
  asio::io_context io;
  tcp::socket s(io);
  s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
  asio::write(s, asio::buffer(bytes));
  boost::system::error_code ec;
  std::array<std::uint8_t, 4096> buf{};
  while (!ec) s.read_some(asio::buffer(buf), ec);  // the host answers or hangs up
}

Bytes HelloFrom(const std::string& serial, std::uint8_t key) {
  return Serialize(ProbeHandshake(serial, KeyOf(key)).Hello());
}

TEST(Transport, HostilePeersAreRejectedWithAReasonAndTheHostStaysUp) {
  Inbox inbox;
  HostLink host(
      HostConfig({{"P-1", KeyOf(1)}}), [&](const LinkCloud& c) { inbox.Take(c); },
      [&](const std::string& l) { inbox.Log(l); });
  host.Start();
  SendRaw(host.Port(), Bytes{'G', 'E', 'T', ' ', '/', '\n'});
  Bytes newer = HelloFrom("P-1", 1);
  newer[4] = kLinkVersion + 1;
  SendRaw(host.Port(), newer);
  Bytes huge = HelloFrom("P-1", 1);
  huge[19] = 0x7f;
  SendRaw(host.Port(), huge);
  SendRaw(host.Port(), HelloFrom("P-9", 1));
  {  // the right serial with the wrong key: the host's challenge cannot be answered
    ProbeHandshake impostor("P-1", KeyOf(2));
    Bytes stream = Serialize(impostor.Hello());
    Frame forged;
    forged.type = MessageType::kAuth;
    forged.payload = Bytes(32, 0);
    const Bytes auth = Serialize(forged);
    stream.insert(stream.end(), auth.begin(), auth.end());
    SendRaw(host.Port(), stream);
  }
  // ... and an honest probe still gets through.
  ProbeLink probe(ProbeConfig("P-1", KeyOf(1), host.Port()), [](const std::string&) {});
  probe.Start();
  std::mt19937 gen(1);
  SubmitAll(probe, {MakeCloud("P-1", 0, &gen)});
  EXPECT_TRUE(probe.WaitAllAcknowledged(kDeliveryTimeout));
  probe.Stop();
  host.Stop();
  for (const char* reason :
       {"bad_magic", "unsupported_version", "oversize", "unknown_probe", "auth_failed"}) {
    EXPECT_TRUE(inbox.Logged(reason)) << reason;
  }
  EXPECT_EQ(inbox.clouds.size(), 1u);
  EXPECT_GE(host.Stats().rejected, 5u);
}

TEST(Transport, WrongKeyProbeNeverDeliversAndKeepsItsClouds) {
  Inbox inbox;
  HostLink host(
      HostConfig({{"P-1", KeyOf(1)}}), [&](const LinkCloud& c) { inbox.Take(c); },
      [&](const std::string& l) { inbox.Log(l); });
  host.Start();
  ProbeLink probe(ProbeConfig("P-1", KeyOf(3), host.Port()), [](const std::string&) {});
  probe.Start();
  std::mt19937 gen(2);
  SubmitAll(probe, {MakeCloud("P-1", 0, &gen)});
  EXPECT_FALSE(probe.WaitAllAcknowledged(500ms));
  EXPECT_EQ(probe.Unacknowledged(), 1u);  // kept for when the key is fixed, not dropped
  probe.Stop();
  host.Stop();
  EXPECT_TRUE(inbox.clouds.empty());
}

TEST(Transport, FullBufferRefusesNewCloudsInsteadOfDroppingOld) {
  ProbeLinkConfig cfg = ProbeConfig("P-1", KeyOf(1), 1);  // port 1: nobody listens
  cfg.buffer_clouds = 3;
  ProbeLink probe(cfg, [](const std::string&) {});
  probe.Start();
  std::mt19937 gen(3);
  for (int i = 0; i < 3; ++i)
    EXPECT_EQ(probe.Submit(MakeCloud("P-1", i, &gen)), SubmitResult::kQueued);
  EXPECT_EQ(probe.Submit(MakeCloud("P-1", 3, &gen)), SubmitResult::kBufferFull);
  EXPECT_EQ(probe.Submit(MakeCloud("P-1", 0, &gen)), SubmitResult::kDuplicate);
  EXPECT_EQ(probe.Unacknowledged(), 3u);
  probe.Stop();
}

TEST(Transport, SeveralProbesAtOnce) {
  Inbox inbox;
  std::map<std::string, Key> keys;
  for (int p = 0; p < 4; ++p)
    keys["P-" + std::to_string(p)] = KeyOf(static_cast<std::uint8_t>(10 + p));
  HostLink host(
      HostConfig(keys), [&](const LinkCloud& c) { inbox.Take(c); },
      [&](const std::string& l) { inbox.Log(l); });
  host.Start();
  std::vector<std::unique_ptr<ProbeLink>> probes;
  std::vector<std::thread> feeders;
  for (const auto& [serial, key] : keys) {
    probes.push_back(std::make_unique<ProbeLink>(ProbeConfig(serial, key, host.Port()),
                                                 [](const std::string&) {}));
    probes.back()->Start();
    // serial = serial: clang 14 cannot capture a structured binding itself.
    feeders.emplace_back([&probe = *probes.back(), serial = serial] {
      std::mt19937 gen(7);
      std::vector<LinkCloud> clouds;
      for (int i = 0; i < 150; ++i) clouds.push_back(MakeCloud(serial, i, &gen));
      SubmitAll(probe, clouds);
    });
  }
  for (auto& t : feeders) t.join();
  for (auto& p : probes) EXPECT_TRUE(p->WaitAllAcknowledged(kDeliveryTimeout));
  for (auto& p : probes) p->Stop();
  host.Stop();
  EXPECT_EQ(inbox.clouds.size(), 600u);
  EXPECT_EQ(inbox.delivered_twice, 0);
}

}  // namespace
}  // namespace mlp::link
