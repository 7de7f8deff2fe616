#include "plant_feed.h"

#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/plant/mqtt.h"

#include <filesystem>

namespace mlp::service {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// The broker password: a file of the host's own, like the probes' keys (owner-only).
std::string ReadPassword(const std::string& path) {
  std::error_code ec;
  const fs::perms p = fs::status(path, ec).permissions();
  if (ec) throw ConfigError("mqtt.password_file " + path + ": cannot be read");
  // A FIFO there blocked the start and SIGTERM with it (issue 48): only a regular file is read.
  if (!fs::is_regular_file(path, ec))
    throw ConfigError("mqtt.password_file " + path + " is not a regular file");
  if ((p & (fs::perms::group_all | fs::perms::others_all)) != fs::perms::none)
    throw ConfigError("mqtt.password_file " + path +
                      " is readable by others: chmod 600 it (it holds the broker password)");
  std::string text = base::ReadFileAs<ConfigError>(path, "mqtt.password_file: ");
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r')) text.pop_back();
  if (text.empty() || text.find('\n') != std::string::npos)
    throw ConfigError("mqtt.password_file " + path + " must hold the password on one line");
  return text;
}

}  // namespace

PlantFeed::PlantFeed(const HostdConfig& config, Log log) {
  if (!config.mqtt) return;
  const MqttConfig& c = *config.mqtt;
  host_id_ = config.host_id;
  prefix_ = c.topic_prefix;
  plant::MqttOptions o;
  o.host = c.host;
  o.port = c.port;
  o.client_id = "mlp-hostd-" + config.host_id;
  o.username = c.username;
  if (!c.password_file.empty()) o.password = ReadPassword(c.password_file);
  o.tls = {c.ca_file, c.cert_file, c.key_file};
  o.keepalive_s = c.keepalive_s;
  o.max_queued = c.max_queued;
  o.will_topic = Topic("status");
  o.will_payload = Stamp({{"state", "offline"}, {"reason", "connection lost"}});
  try {
    publisher_ = std::make_unique<plant::MqttPublisher>(o, std::move(log));
  } catch (const plant::MqttError& e) {
    throw ConfigError(config.path + ": " + e.what());
  }
}

PlantFeed::~PlantFeed() {
  if (!publisher_) return;
  publisher_->Publish(Topic("status"), Stamp({{"state", "offline"}, {"reason", "stopped"}}), true);
}

std::string PlantFeed::Topic(const std::string& tail) const {
  return prefix_ + "/" + host_id_ + "/" + tail;
}

json PlantFeed::Stamp(json payload) const {
  payload["host"] = host_id_;
  payload["time_utc"] = base::UtcNow("%Y-%m-%dT%H:%M:%SZ", false);
  return payload;
}

void PlantFeed::Answered(const std::string& machine, const std::string& op, const json& reply) {
  if (!publisher_) return;
  json message = reply;
  message["op"] = op;
  message["machine"] = machine;
  message = Stamp(message);
  const std::string base = "machine/" + machine + "/";
  publisher_->Publish(Topic(base + "result"), message);
  // A refusal: the job said so, or the request never became one (busy, unreadable).
  const std::string status = reply.value("status", "");
  if (status == "refused" || (!reply.contains("job_id") && !reply.value("ok", false)))
    publisher_->Publish(Topic(base + "refusal"), message);
}

void PlantFeed::OffsetsWritten(const std::string& machine,
                               std::int64_t job,
                               const std::vector<history::OffsetWriteRow>& rows) {
  if (!publisher_) return;
  for (const history::OffsetWriteRow& row : rows)
    publisher_->Publish(Topic("machine/" + machine + "/offset"), Stamp({{"machine", machine},
                                                                        {"job_id", job},
                                                                        {"adapter", row.adapter},
                                                                        {"target", row.target},
                                                                        {"before", row.before},
                                                                        {"after", row.after}}));
}

void PlantFeed::Status(const json& host_status) {
  // Not held while the broker is away: only the newest counts, and the next period sends it.
  if (!publisher_ || !publisher_->Counters().connected) return;
  json status = host_status;
  status.erase("ok");
  status["state"] = "online";
  publisher_->Publish(Topic("status"), Stamp(status), true);
  for (const json& probe : host_status.value("probes", json::array()))
    publisher_->Publish(Topic("probe/" + probe.at("serial").get<std::string>() + "/status"),
                        Stamp(probe), true);
}

json PlantFeed::Counters() const {
  if (!publisher_) return nullptr;
  const plant::MqttCounters c = publisher_->Counters();
  return {{"connected", c.connected},
          {"published", c.published},
          {"queued", c.queued},
          {"dropped", c.dropped},
          {"last_error", c.last_error}};
}

}  // namespace mlp::service
