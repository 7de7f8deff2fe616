// mlp-hostd's configuration: the sample file as shipped, and typed errors naming the field.

#include "mlp/service/config.h"

#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::service {
namespace {

const std::string kSample = mlp::test::SourceDir() + "/samples/hostd/hostd.json";

TEST(HostdConfig, TheSampleReads) {
  const HostdConfig c = LoadHostdConfig(kSample);
  EXPECT_EQ(c.data_dir, "/var/lib/mlprobe");
  EXPECT_EQ(c.link_port, 7420);
  ASSERT_EQ(c.machines.size(), 2u);
  const MachineConfig* vmc = c.Machine("vmc-1");
  ASSERT_NE(vmc, nullptr);
  EXPECT_EQ(vmc->controller.kind, ControllerConfig::Kind::kLinuxCnc);
  EXPECT_EQ(vmc->limits.max_offset_change_mm, 0.2);
  const MachineConfig* hmc = c.Machine("hmc-2");
  ASSERT_NE(hmc, nullptr);
  EXPECT_EQ(hmc->controller.kind, ControllerConfig::Kind::kFanucStyle);
  EXPECT_TRUE(hmc->controller.map.use_variables);
  EXPECT_EQ(hmc->controller.map.rotation_var, 500);
  EXPECT_EQ(hmc->controller.map.radius_wear_var, 12001);  // the Fanuc preset
  EXPECT_EQ(hmc->limits.min_points, 200);                 // defaults where not given
  EXPECT_EQ(c.Machine("nope"), nullptr);
  EXPECT_EQ(c.HistoryFile(), "/var/lib/mlprobe/history.sqlite");
}

TEST(HostdConfig, RelativePathsFollowTheFile) {
  const HostdConfig c = ParseHostdConfig(
      R"({"format": "mlprobe-hostd/1", "data_dir": "data", "job_socket": "run/jobs.sock",
          "probe_link": {"address": "127.0.0.1", "port": 7000},
          "probes": [{"serial": "P", "key_file": "keys/p.key"}],
          "machines": [{"name": "m", "probe": "P",
                        "controller": {"kind": "files", "result_dir": "../out"}}]})",
      "/etc/mlprobe/hostd.json");
  EXPECT_EQ(c.data_dir, "/etc/mlprobe/data");
  EXPECT_EQ(c.probes[0].key_file, "/etc/mlprobe/keys/p.key");
  EXPECT_EQ(c.machines[0].controller.result_dir, "/etc/out");
}

// A whole configuration up to its machines.
const std::string kHead =
    R"({"format": "mlprobe-hostd/1", "data_dir": "/d", "job_socket": "/s",
        "probe_link": {"address": "127.0.0.1", "port": 7000},
        "probes": [{"serial": "P", "key_file": "/k"}], )";

void ExpectError(const std::string& text, const std::string& needle) {
  try {
    ParseHostdConfig(text, "/etc/h.json");
    ADD_FAILURE() << "accepted: " << needle;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
  }
}

TEST(HostdConfig, ErrorsNameTheField) {
  const std::string machine =
      R"({"name": "m", "probe": "P", "controller": {"kind": "files", "result_dir": "/o"}})";
  ExpectError(kHead + R"("machines": []})", "machines must list at least one");
  ExpectError(kHead + R"("machines": [)" + machine + "," + machine + "]}", "machines[1].name");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "Q", "controller": {"kind": "files",
                  "result_dir": "/o"}}]})",
              "\"Q\" is not one of the probes");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "heidenhain",
                  "result_dir": "/o"}}]})",
              "machines[0].controller.kind");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "files",
                  "result_dir": "/o"}, "limits": {"max_offset_change_mm": -1}}]})",
              "max_offset_change_mm");
  ExpectError(R"({"format": "mlprobe-hostd/1", "data_dir": "/d", "job_socket": "/s",
                  "probe_link": {"address": "x", "port": 70000}})",
              "probe_link.port");
  ExpectError(R"({"format": "mlprobe-hostd/2"})", "format");
  // Issue 48: a machine's name names its files (reports/<machine>-job<N>.svg): never a path.
  for (const char* name : {"../../../escaped", "a/b", ".hidden", ""})
    ExpectError(kHead + R"("machines": [{"name": ")" + name +
                    R"(", "probe": "P", "controller": {"kind": "files", "result_dir": "/o"}}]})",
                "machines[0].name");
}

// The plant's MQTT feed: optional, paths relative to the file, and names that go into topics
// must be valid topic levels.
TEST(HostdConfig, TheMqttFeedIsOptionalAndItsNamesMustBeTopicLevels) {
  const std::string machine =
      R"({"name": "m", "probe": "P", "controller": {"kind": "files", "result_dir": "/o"}})";
  EXPECT_FALSE(ParseHostdConfig(kHead + R"("machines": [)" + machine + "]}", "/etc/h.json").mqtt);
  const HostdConfig c = ParseHostdConfig(
      kHead + R"("machines": [)" + machine +
          R"(], "host_id": "cell3", "mqtt": {"host": "broker.plant", "port": 8883, "username": "cell3", "password_file": "mqtt.pass",
      "tls": {"ca_file": "plant-ca.crt"}, "status_period_s": 5}})",
      "/etc/mlprobe/hostd.json");
  ASSERT_TRUE(c.mqtt);
  EXPECT_EQ(c.mqtt->host, "broker.plant");
  EXPECT_EQ(c.mqtt->port, 8883);
  EXPECT_EQ(c.mqtt->topic_prefix, "mlprobe");
  EXPECT_EQ(c.mqtt->password_file, "/etc/mlprobe/mqtt.pass");
  EXPECT_EQ(c.mqtt->ca_file, "/etc/mlprobe/plant-ca.crt");
  EXPECT_EQ(c.mqtt->status_period_s, 5);
  EXPECT_EQ(c.host_id, "cell3");
  const std::string with = kHead + R"("machines": [)" + machine + R"(], "mqtt": )";
  ExpectError(kHead + R"("machines": [)" + machine + R"(], "host_id": "a/b", "mqtt": {"host":
              "b"}})",
              "host_id");
  ExpectError(with + R"({"host": "b", "topic_prefix": "plant/#"}})", "mqtt.topic_prefix");
  ExpectError(with + R"({"host": "b", "port": 0}})", "mqtt.port");
  ExpectError(with + R"({"host": "b", "username": "u"}})", "password_file");
  ExpectError(with + R"({"host": "b", "qos": 2}})", "mqtt");
  // Issue 48: 1e-9 s was taken (33,000 retained publishes in 3 s).
  ExpectError(with + R"({"host": "b", "status_period_s": 1e-9}})",
              "mqtt.status_period_s must be at least 0.1 s");
  ExpectError(kHead + R"("machines": [{"name": "bay+3", "probe": "P", "controller": {"kind":
              "files", "result_dir": "/o"}}], "mqtt": {"host": "b"}})",
              "machines[].name");
  // Without the feed a machine's name is free.
  EXPECT_NO_THROW(ParseHostdConfig(kHead + R"("machines": [{"name": "bay+3", "probe": "P",
      "controller": {"kind": "files", "result_dir": "/o"}}]})",
                                   "/etc/h.json"));
}

// A misspelled field used to be ignored, leaving its default in force without a word.
TEST(HostdConfig, UnknownFieldsAreRefusedWithTheNearestName) {
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "job_timout_s": 60,
                  "controller": {"kind": "files", "result_dir": "/o"}}]})",
              "machines[0].job_timout_s is not a known field (did you mean \"job_timeout_s\"?)");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "files",
                  "result_dir": "/o"}, "limits": {"max_rms": 0.01}}]})",
              "limits.max_rms is not a known field (did you mean \"max_rms_mm\"?)");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "linuxcnc",
                  "result_dir": "/o", "tool_table": "/t", "write_tool_tabel": true}}]})",
              "did you mean \"write_tool_table\"");
  ExpectError(kHead + R"("machines": [], "colour": "red"})",
              "config.colour is not a known field");  // nothing near: no hint
  // A flag that is not a flag is refused, never read as false.
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "fanuc",
                  "result_dir": "/o", "use_variables": "yes"}}]})",
              "use_variables must be true or false");
  // A comment is allowed anywhere.
  EXPECT_NO_THROW(
      ParseHostdConfig(kHead + R"("machines": [{"name": "m", "probe": "P", "comment": "cell 3",
               "controller": {"kind": "files", "result_dir": "/o"}}]})",
                       "/etc/h.json"));
}

// 1e308 s once overflowed the wait's conversion to a negative duration.
TEST(HostdConfig, TimeoutsAreBounded) {
  const std::string machines =
      R"("machines": [{"name": "m", "probe": "P", "controller": {"kind": "files",
         "result_dir": "/o"}}]})";
  ExpectError(kHead + R"("capture_timeout_s": 1e308, )" + machines,
              "capture_timeout_s must be at most 86400 s");
  ExpectError(kHead +
                  R"("machines": [{"name": "m", "probe": "P", "job_timeout_s": 86401,
                  "controller": {"kind": "files", "result_dir": "/o"}}]})",
              "job_timeout_s must be at most 86400 s");
  ExpectError(kHead + R"("capture_timeout_s": 1e400, )" + machines, "not valid JSON");
  const HostdConfig c =
      ParseHostdConfig(kHead + R"("capture_timeout_s": 86400, )" + machines, "/etc/h.json");
  EXPECT_EQ(c.capture_timeout_s, 86400.0);
}

}  // namespace
}  // namespace mlp::service
