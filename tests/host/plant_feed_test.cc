// mlp-hostd's live feed to the plant: a real Mosquitto broker (TLS, user and password), a real
// mlp-hostd running relocate jobs (no probe needed), a subscriber for the quality engineer.
// Every answer on .../result, refusals on .../refusal as well, the offsets written on
// .../offset, the retained status, the last will when the host dies, "stopped" when it stops;
// the broker away: jobs still run and their messages arrive when it is back.

#include <filesystem>
#include <fstream>

#include "electrode_site.h"
#include "garbage_server.h"
#include "plant/broker.h"
#include <sys/stat.h>

namespace mlp::test {
namespace {

const BrokerUser kHostUser{"cell3-host", "h0st-secret"}, kQuality{"quality", "qa-secret"};
const std::string kResult = "mlprobe/cell3/machine/lcnc-1/result";

// A site whose lcnc-1 is an EDM sinker with C, feeding `broker` over TLS as host "cell3"; the
// electrode's textures before, after (turned and shifted) and tilted beyond the limit.
void PlantSite(const Site& site, const Broker& broker, int port, bool tls) {
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  std::ofstream(site.dir / "mqtt.pass") << kHostUser.password << "\n";
  fs::permissions(site.dir / "mqtt.pass", fs::perms::owner_read | fs::perms::owner_write);
  config["host_id"] = "cell3";
  config["mqtt"] = {{"host", "127.0.0.1"},
                    {"port", port},
                    {"username", kHostUser.name},
                    {"password_file", "mqtt.pass"},
                    {"status_period_s", 0.5}};
  if (tls) config["mqtt"]["tls"] = {{"ca_file", broker.ca_file()}};
  ElectrodeSite(site, config);
}

// Issue 48: the broker password in nothing a plant test's programs said: their outputs, the
// host's logs, every message the plant received.
void ExpectNoPassword(const Site& site,
                      const Subscriber& plant,
                      const std::vector<ProcessRun>& runs) {
  std::string printed;
  for (const ProcessRun& r : runs) printed += r.out + r.err;
  for (const char* log : {"hostd.log", "hostd2.log"})
    if (fs::exists(site.dir / log)) printed += ReadText(site.dir / log);
  for (const auto& m : plant.Messages()) printed += m.topic + m.payload.dump();
  EXPECT_EQ(printed.find(kHostUser.password), std::string::npos);
}

bool StatusIs(const Subscriber& s, const std::string& state, const std::string& reason = "") {
  return Eventually([&] {
    const auto all = s.Messages();
    for (auto it = all.rbegin(); it != all.rend(); ++it)
      if (it->topic == "mlprobe/cell3/status")
        return it->payload.value("state", "") == state &&
               (reason.empty() || it->payload.value("reason", "") == reason);
    return false;
  });
}

TEST(PlantFeed, ResultsRefusalsOffsetsAndStatusReachTheBrokerOverTls) {
  Broker broker("hostd_feed", {kHostUser, kQuality});
  Site site("plant_feed", 17465);
  PlantSite(site, broker, broker.tls_port(), /*tls=*/true);
  if (HasFatalFailure()) return;
  Subscriber quality(broker, kQuality, "mlprobe/#", "quality-hostd");
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(StatusIs(quality, "online")) << ReadText(site.dir / "hostd.log");
  const auto online = quality.On("mlprobe/cell3/status").back();
  EXPECT_EQ(online.payload.at("machines").size(), 2u);
  EXPECT_EQ(online.payload.at("host"), "cell3");
  const auto probe = quality.On("mlprobe/cell3/probe/MLP-REF-0001/status");
  ASSERT_FALSE(probe.empty());
  EXPECT_EQ(probe.back().payload.at("connected"), false);
  const auto status = site.Mlp("status");
  EXPECT_NE(status.out.find("plant feed (MQTT): connected"), std::string::npos) << status.out;

  // Refused (tilted beyond the limit): on result and on refusal.
  const auto tilted = site.Mlp("request " + site.Request("tilted", RelocateJob("tilted")));
  EXPECT_EQ(tilted.exit_code, 6) << tilted.err;
  const auto refusals = quality.On("mlprobe/cell3/machine/lcnc-1/refusal");
  ASSERT_EQ(refusals.size(), 1u);
  EXPECT_EQ(refusals[0].payload.at("status"), "refused");
  EXPECT_EQ(refusals[0].payload.at("op"), "relocate");
  EXPECT_NE(refusals[0].payload.at("error").get<std::string>().find("clamp it again"),
            std::string::npos);

  // Done: the reply on result, T30's change on offset with its values before and after.
  const auto run = site.Mlp("request " + site.Request("after", RelocateJob("after")) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const json reply = json::parse(run.out);
  const auto results = quality.On(kResult, 2);
  ASSERT_EQ(results.size(), 2u);
  EXPECT_EQ(results[1].payload.at("job_id"), reply.at("job_id"));
  EXPECT_EQ(results[1].payload.at("update"), reply.at("update"));
  EXPECT_EQ(results[1].payload.at("status"), "done");
  // T30's X, Y, Z and C: one message each, as the history records them.
  const auto offsets = quality.On("mlprobe/cell3/machine/lcnc-1/offset", 4);
  ASSERT_EQ(offsets.size(), 4u);
  for (const auto& offset : offsets) {
    EXPECT_EQ(offset.payload.at("job_id"), reply.at("job_id"));
    EXPECT_NE(offset.payload.at("target").get<std::string>().find("30"), std::string::npos)
        << offset.payload;
    EXPECT_NE(offset.payload.at("before"), offset.payload.at("after")) << offset.payload;
  }
  EXPECT_EQ(quality.On("mlprobe/cell3/machine/lcnc-1/refusal").size(), 1u);  // no more

  // The host dies: the broker says so for it (the last will, retained).
  hostd.Stop(SIGKILL);
  EXPECT_TRUE(StatusIs(quality, "offline", "connection lost"));
  // Started again and stopped: online, then "stopped".
  Child again({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd2.log");
  ASSERT_TRUE(StatusIs(quality, "online")) << ReadText(site.dir / "hostd2.log");
  const auto status_json = site.Mlp("status --json");
  EXPECT_EQ(again.Stop(), 0);
  EXPECT_TRUE(StatusIs(quality, "offline", "stopped"));
  ExpectNoPassword(site, quality, {status, tilted, run, status_json});
}

TEST(PlantFeed, ABrokerAwayStopsNoJobAndGetsItsMessagesWhenBack) {
  Broker broker("hostd_away", {kHostUser, kQuality});
  Site site("plant_away", 17466);
  PlantSite(site, broker, broker.port(), /*tls=*/false);
  if (HasFatalFailure()) return;
  Subscriber quality(broker, kQuality, "mlprobe/+/machine/#", "quality-away-hostd", true);
  broker.Stop();
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }))
      << ReadText(site.dir / "hostd.log");
  const auto status = site.Mlp("status");
  EXPECT_NE(status.out.find("plant feed (MQTT): NOT connected"), std::string::npos) << status.out;
  const auto run = site.Mlp("request " + site.Request("after", RelocateJob("after")) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;  // the job ran and wrote, the broker away
  EXPECT_NE(ReadText(site.dir / "tool.tbl"), kElectrodeTable);
  const json held = json::parse(site.Mlp("status --json").out).at("mqtt");
  EXPECT_EQ(held.at("queued"), 5);  // the result and T30's four offsets (no status: not held)
  EXPECT_EQ(held.at("connected"), false);
  broker.Start();
  const auto results = quality.On(kResult);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].payload.at("job_id"), json::parse(run.out).at("job_id"));
  EXPECT_EQ(quality.On("mlprobe/cell3/machine/lcnc-1/offset", 4).size(), 4u);
  EXPECT_NE(ReadText(site.dir / "hostd.log").find("messages held meanwhile"), std::string::npos);
  ExpectNoPassword(site, quality, {status, run});
}

// Issue 48, item 1: a plant database address where another service answers with bytes that are
// not UTF-8. libpq quotes them in its error, the status thread published that error, and
// nlohmann's dump threw: mlp-hostd aborted about 1 s after every start. A relocate job whose
// images.json ends in such bytes had its reply replaced by the same exception.
TEST(PlantFeed, BytesThatAreNotUtf8FromThePlantOrAFileStopNeitherTheHostNorItsFeed) {
  Broker broker("hostd_utf8", {kHostUser, kQuality});
  GarbageServer garbage;
  Site site("plant_utf8", 17478);
  PlantSite(site, broker, broker.port(), /*tls=*/false);
  if (HasFatalFailure()) return;
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["plant_database"] = {
      {"connection", "postgresql://mlp@127.0.0.1:" + std::to_string(garbage.port()) + "/plant"}};
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  Subscriber quality(broker, kQuality, "mlprobe/#", "quality-utf8");
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(StatusIs(quality, "online")) << ReadText(site.dir / "hostd.log");

  // images.json ending in bytes ff fe: a typed failure in the reply and on the feed.
  fs::create_directories(site.dir / "data" / "tools" / "bad");
  fs::copy(site.dir / "data" / "tools" / "after", site.dir / "data" / "tools" / "bad",
           fs::copy_options::recursive | fs::copy_options::overwrite_existing);
  std::ofstream(site.dir / "data" / "tools" / "bad" / "images.json", std::ios::app) << "\xff\xfe";
  const auto bad = site.Mlp("request " + site.Request("bad", RelocateJob("bad")) + " --json");
  EXPECT_NE(bad.exit_code, 0);
  ASSERT_FALSE(bad.out.empty()) << bad.err;
  const json reply = json::parse(bad.out);
  EXPECT_EQ(reply.at("ok"), false);
  EXPECT_EQ(reply.at("error").get<std::string>().find("type_error"), std::string::npos) << bad.out;
  EXPECT_NE(reply.at("error").get<std::string>().find("images.json"), std::string::npos) << bad.out;
  const auto results = quality.On(kResult);
  ASSERT_EQ(results.size(), 1u);
  EXPECT_EQ(results[0].payload.at("job_id"), reply.at("job_id"));

  // That job waits for the plant database, whose address answers bytes that are not UTF-8:
  // the forwarder's error quotes them, and several status periods (0.5 s) publish it.
  ASSERT_TRUE(Eventually([&] { return garbage.answered() >= 2; }))
      << ReadText(site.dir / "hostd.log");
  const std::size_t seen = quality.On("mlprobe/cell3/status").size();
  const auto status = quality.On("mlprobe/cell3/status", seen + 3);
  ASSERT_GE(status.size(), seen + 3) << ReadText(site.dir / "hostd.log");
  const std::string error = status.back().payload.at("plant_database").at("last_error");
  EXPECT_FALSE(error.empty());
  const auto polled = site.Mlp("status --json");
  ASSERT_EQ(polled.exit_code, 0) << polled.err << ReadText(site.dir / "hostd.log");
  EXPECT_TRUE(hostd.Alive()) << ReadText(site.dir / "hostd.log");
  EXPECT_EQ(hostd.Stop(), 0) << ReadText(site.dir / "hostd.log");
  ExpectNoPassword(site, quality, {bad, polled});
}

TEST(PlantFeed, APasswordFileOthersCanReadStopsTheStart) {
  Broker broker("hostd_pass", {kHostUser});
  Site site("plant_pass", 17467);
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  std::ofstream(site.dir / "mqtt.pass") << kHostUser.password << "\n";
  fs::permissions(site.dir / "mqtt.pass", fs::perms::owner_read | fs::perms::others_read);
  config["mqtt"] = {{"host", "127.0.0.1"},
                    {"port", broker.port()},
                    {"username", kHostUser.name},
                    {"password_file", "mqtt.pass"}};
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  const auto r = RunProcess(kHostd + " --config " + (site.dir / "hostd.json").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("chmod 600"), std::string::npos) << r.err;
  // Issue 48: a FIFO in its place blocked the start (and SIGTERM) waiting for a writer.
  fs::remove(site.dir / "mqtt.pass");
  ASSERT_EQ(mkfifo((site.dir / "mqtt.pass").c_str(), 0600), 0);
  const auto fifo = RunProcess(kHostd + " --config " + (site.dir / "hostd.json").string());
  EXPECT_EQ(fifo.exit_code, 2);
  EXPECT_NE(fifo.err.find("is not a regular file"), std::string::npos) << fifo.err;
}

}  // namespace
}  // namespace mlp::test
