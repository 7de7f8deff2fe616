// The plant's MQTT client against a real Mosquitto broker started by the test: QoS 1 delivery
// with user and password, a wrong password refused, a retained status for a late subscriber,
// messages kept while the broker is away and delivered when it is back, TLS with the broker's
// certificate checked.

#include "mlp/plant/mqtt.h"

#include <algorithm>
#include <mutex>

#include "broker.h"
#include <gtest/gtest.h>

namespace mlp::plant {
namespace {

using json = nlohmann::json;
using test::Broker;
using test::BrokerUser;
using test::Subscriber;

const BrokerUser kHost{"cell3-host", "h0st-secret"}, kQuality{"quality", "qa-secret"};

struct Lines {
  std::mutex m;
  std::vector<std::string> lines;
  MqttLog Log() {
    return [this](const std::string& l) {
      std::lock_guard lock(m);
      lines.push_back(l);
    };
  }
  bool Has(const std::string& part) {
    std::lock_guard lock(m);
    for (const auto& l : lines)
      if (l.find(part) != std::string::npos) return true;
    return false;
  }
};

MqttOptions HostOptions(const Broker& b, const std::string& id) {
  MqttOptions o;
  o.port = b.port();
  o.client_id = id;
  o.username = kHost.name;
  o.password = kHost.password;
  return o;
}

TEST(Mqtt, DeliversEveryMessageOnceAcknowledgedWithUserAndPassword) {
  Broker broker("deliver", {kHost, kQuality});
  Subscriber quality(broker, kQuality, "mlprobe/#", "quality-deliver");
  Lines log;
  {
    MqttPublisher host(HostOptions(broker, "host-deliver"), log.Log());
    constexpr int kMessages = 200;
    for (int i = 0; i < kMessages; ++i)
      EXPECT_TRUE(host.Publish("mlprobe/cell3/machine/vmc-1/result", {{"job_id", i}}));
    EXPECT_TRUE(host.Flush(std::chrono::seconds(30)));
    const MqttCounters c = host.Counters();
    EXPECT_TRUE(c.connected);
    EXPECT_EQ(c.published, kMessages);
    EXPECT_EQ(c.queued, 0);
    EXPECT_EQ(c.dropped, 0);
    const auto got = quality.On("mlprobe/cell3/machine/vmc-1/result", kMessages);
    ASSERT_EQ(got.size(), static_cast<std::size_t>(kMessages));
    for (int i = 0; i < kMessages; ++i) EXPECT_EQ(got[i].payload.at("job_id"), i);  // in order
  }
  EXPECT_TRUE(log.Has("connected to 127.0.0.1:"));
  EXPECT_FALSE(log.Has(HostOptions(broker, "host-deliver").password));  // issue 48
}

TEST(Mqtt, AWrongPasswordIsRefusedAndSaidNotPublished) {
  Broker broker("refuse", {kHost, kQuality});
  Subscriber quality(broker, kQuality, "#", "quality-refuse");
  Lines log;
  MqttOptions o = HostOptions(broker, "host-refuse");
  o.password = "guess-7Qz";
  MqttPublisher host(o, log.Log());
  ASSERT_TRUE(test::Eventually([&] { return !host.Counters().last_error.empty(); }));
  EXPECT_FALSE(host.Counters().connected);
  EXPECT_NE(host.Counters().last_error.find("not authorised"), std::string::npos)
      << host.Counters().last_error;
  EXPECT_TRUE(log.Has("refused the connection"));
  // Issue 48: the password is in nothing the library says.
  EXPECT_FALSE(log.Has(o.password));
  EXPECT_EQ(host.Counters().last_error.find(o.password), std::string::npos);
  host.Publish("mlprobe/x", {{"a", 1}});
  EXPECT_FALSE(host.Flush(std::chrono::milliseconds(500)));
  EXPECT_EQ(host.Counters().published, 0);
  EXPECT_TRUE(quality.Messages().empty());
}

TEST(Mqtt, ARetainedStatusReachesASubscriberThatComesLater) {
  Broker broker("retain", {kHost, kQuality});
  MqttPublisher host(HostOptions(broker, "host-retain"), {});
  host.Publish("mlprobe/cell3/status", {{"state", "online"}, {"n", 1}}, true);
  host.Publish("mlprobe/cell3/status", {{"state", "online"}, {"n", 2}}, true);
  ASSERT_TRUE(host.Flush(std::chrono::seconds(30)));
  Subscriber late(broker, kQuality, "mlprobe/+/status", "quality-late");
  const auto got = late.On("mlprobe/cell3/status");
  ASSERT_EQ(got.size(), 1u);  // the newest only
  EXPECT_TRUE(got[0].retained);
  EXPECT_EQ(got[0].payload.at("n"), 2);
}

TEST(Mqtt, MessagesWaitWhileTheBrokerIsAwayAndArriveWhenItIsBack) {
  Broker broker("away", {kHost, kQuality});
  // A persistent session (the broker keeps it, and messages for it, over its restart).
  Subscriber quality(broker, kQuality, "mlprobe/#", "quality-away", /*persistent=*/true);
  MqttPublisher host(HostOptions(broker, "host-away"), {});
  host.Publish("mlprobe/cell3/machine/vmc-1/result", {{"job_id", 1}});
  ASSERT_TRUE(host.Flush(std::chrono::seconds(30)));
  broker.Stop();
  ASSERT_TRUE(test::Eventually([&] { return !host.Counters().connected; }));
  for (int job = 2; job <= 4; ++job)
    EXPECT_TRUE(host.Publish("mlprobe/cell3/machine/vmc-1/result", {{"job_id", job}}));
  EXPECT_EQ(host.Counters().queued, 3);
  broker.Start();
  EXPECT_TRUE(host.Flush(std::chrono::seconds(60)));
  // QoS 1 is at least once: the broker may deliver job 1 again after its restart (the
  // subscriber's acknowledgement can be cut by the stop; seen in a sanitized run). What must
  // hold: every job arrives, first in the order sent, and nothing else.
  std::vector<int> first_seen;
  std::size_t messages = 0;
  EXPECT_TRUE(test::Eventually([&] {
    first_seen.clear();
    const auto got = quality.On("mlprobe/cell3/machine/vmc-1/result");
    messages = got.size();
    for (const auto& m : got) {
      const int job = m.payload.at("job_id");
      if (std::find(first_seen.begin(), first_seen.end(), job) == first_seen.end())
        first_seen.push_back(job);
    }
    return first_seen.size() >= 4;
  }));
  EXPECT_EQ(first_seen, (std::vector<int>{1, 2, 3, 4}));
  EXPECT_LE(messages, 5u);  // at most job 1 twice: the others were held by our client
}

TEST(Mqtt, TheQueueIsBoundedWhileTheBrokerIsAway) {
  MqttOptions o;
  o.port = test::FreePort();  // nobody listens
  o.client_id = "host-bounded";
  o.max_queued = 5;
  MqttPublisher host(o, {});
  for (int i = 0; i < 8; ++i) host.Publish("mlprobe/x", {{"i", i}});
  const MqttCounters c = host.Counters();
  EXPECT_FALSE(c.connected);
  EXPECT_EQ(c.queued, 5);
  EXPECT_EQ(c.dropped, 3);
}

TEST(Mqtt, TlsChecksTheBrokersCertificate) {
  Broker broker("tls", {kHost, kQuality});
  Subscriber quality(broker, kQuality, "mlprobe/#", "quality-tls");
  MqttOptions o = HostOptions(broker, "host-tls");
  o.port = broker.tls_port();
  o.tls.ca_file = broker.ca_file();
  {
    MqttPublisher host(o, {});
    host.Publish("mlprobe/cell3/status", {{"state", "online"}});
    EXPECT_TRUE(host.Flush(std::chrono::seconds(30)));
  }
  EXPECT_EQ(quality.On("mlprobe/cell3/status").size(), 1u);

  // Another CA: the broker's certificate is not trusted, nothing goes out.
  const auto other = broker.dir() / "other";
  std::filesystem::create_directories(other);
  Broker::MakeCertificates(other, "ca", "unused");
  o.client_id = "host-tls-other";
  o.tls.ca_file = (other / "ca.crt").string();
  MqttPublisher stranger(o, {});
  stranger.Publish("mlprobe/cell3/status", {{"state", "stranger"}});
  EXPECT_FALSE(stranger.Flush(std::chrono::seconds(2)));
  EXPECT_FALSE(stranger.Counters().connected);
  EXPECT_EQ(quality.On("mlprobe/cell3/status").size(), 1u);
}

TEST(Mqtt, RefusesOptionsItCannotUseAndTopicLevelsWithWildcards) {
  MqttOptions o;
  o.client_id = "";
  EXPECT_THROW(MqttPublisher(o, {}), MqttError);
  o.client_id = "x";
  o.tls.ca_file = "/nonexistent/ca.crt";
  EXPECT_THROW(MqttPublisher(o, {}), MqttError);
  o.tls = {};
  o.tls.cert_file = "/etc/hostname";
  EXPECT_THROW(MqttPublisher(o, {}), MqttError);  // a certificate without its CA and key
  o.tls = {};
  o.port = 0;
  EXPECT_THROW(MqttPublisher(o, {}), MqttError);
  for (const std::string& bad :
       std::vector<std::string>{"", "a/b", "vmc+1", "#", "a\nb", std::string(65, 'm')})
    EXPECT_THROW(CheckTopicLevel(bad, "machine"), MqttError) << bad;
  EXPECT_NO_THROW(CheckTopicLevel("vmc-1 (bay 3)", "machine"));
}

}  // namespace
}  // namespace mlp::plant
