#include "mlp/service/config.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/plant/mqtt.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <unistd.h>

namespace mlp::service {
namespace {

namespace fs = std::filesystem;
namespace jf = base::json_fields;
using json = nlohmann::json;
constexpr const char* kFormat = "mlprobe-hostd/1";

struct Reader {
  std::string file;
  fs::path base;

  std::string Where(const std::string& field) const { return file + ": " + field; }
  [[noreturn]] void Fail(const std::string& field, const std::string& what) const {
    throw ConfigError(Where(field) + " " + what);
  }
  std::string Path(const json& j, const char* key, const std::string& where) const {
    const std::string p = jf::Text<ConfigError>(j, key, Where(where));
    if (p.empty()) Fail(where + "." + key, "must not be empty");
    return fs::path(p).is_absolute() ? p : (base / p).lexically_normal().string();
  }
  double Positive(const json& j, const char* key, double fallback, const std::string& w) const {
    const double v = jf::NumberOr<ConfigError>(j, key, fallback, Where(w));
    if (!(v > 0)) Fail(w + "." + key, "must be > 0");
    return v;
  }
  /// A wait [s]: more than a day is a typo, and 1e308 s once overflowed to a negative wait.
  double Seconds(const json& j, const char* key, double fallback, const std::string& w) const {
    const double v = Positive(j, key, fallback, w);
    if (v > kMaxWaitS) Fail(w + "." + key, "must be at most " + std::to_string(kMaxWaitS) + " s");
    return v;
  }
  bool Flag(const json& j, const char* key, const std::string& w) const {
    return jf::FlagOr<ConfigError>(j, key, false, Where(w));
  }
  void OnlyKnown(const json& j,
                 std::initializer_list<std::string_view> known,
                 const std::string& w) const {
    jf::OnlyKnownFields<ConfigError>(j, known, Where(w));
  }
  static constexpr int kMaxWaitS = 86400;
};

features::PlausibilityLimits ParseLimits(const Reader& r, const json& m, const std::string& w) {
  features::PlausibilityLimits l;
  if (!m.contains("limits")) return l;
  const json& j = jf::Object<ConfigError>(m, "limits", r.Where(w));
  const std::string lw = w + ".limits";
  r.OnlyKnown(
      j,
      {"min_points", "min_arc_span_deg", "min_area_mm2", "max_rms_mm", "max_calibration_age_h",
       "max_offset_change_mm", "max_work_shift_mm", "max_tilt_deg"},
      lw);
  l.min_points = static_cast<int>(r.Positive(j, "min_points", l.min_points, lw));
  l.min_arc_span_deg = jf::NumberOr<ConfigError>(j, "min_arc_span_deg", l.min_arc_span_deg, lw);
  l.min_area_mm2 = jf::NumberOr<ConfigError>(j, "min_area_mm2", l.min_area_mm2, lw);
  l.max_rms_mm = r.Positive(j, "max_rms_mm", l.max_rms_mm, lw);
  l.max_calibration_age_h = r.Positive(j, "max_calibration_age_h", l.max_calibration_age_h, lw);
  l.max_offset_change_mm = r.Positive(j, "max_offset_change_mm", l.max_offset_change_mm, lw);
  l.max_work_shift_mm = r.Positive(j, "max_work_shift_mm", l.max_work_shift_mm, lw);
  l.max_tilt_deg = r.Positive(j, "max_tilt_deg", l.max_tilt_deg, lw);
  return l;
}

ControllerConfig ParseController(const Reader& r, const json& m, const std::string& w) {
  const json& j = jf::Object<ConfigError>(m, "controller", r.Where(w));
  const std::string cw = w + ".controller";
  const std::string kind = jf::Text<ConfigError>(j, "kind", r.Where(cw));
  ControllerConfig c;
  c.result_dir = r.Path(j, "result_dir", cw);
  if (kind == "linuxcnc") {
    r.OnlyKnown(j,
                {"kind", "result_dir", "tool_table", "write_tool_table", "axes", "kinematics_hal",
                 "max_pivot_change_mm", "comment"},
                cw);
    c.kind = ControllerConfig::Kind::kLinuxCnc;
    c.tool_table = r.Path(j, "tool_table", cw);
    if (j.contains("kinematics_hal")) c.kinematics_hal = r.Path(j, "kinematics_hal", cw);
    c.max_pivot_change_mm = r.Positive(j, "max_pivot_change_mm", c.max_pivot_change_mm, cw);
    c.write_tool_table = r.Flag(j, "write_tool_table", cw);
    if (j.contains("axes")) c.axes = jf::Text<ConfigError>(j, "axes", r.Where(cw));
    if (c.axes.empty() || c.axes.size() > 9 ||
        c.axes.find_first_not_of("XYZABCUVW") != std::string::npos)
      throw ConfigError(r.Where(cw) +
                        ".axes must be letters of XYZABCUVW (LinuxCNC's "
                        "COORDINATES without spaces)");
  } else if (kind == "fanuc" || kind == "haas" || kind == "syntec") {
    r.OnlyKnown(j,
                {"kind", "result_dir", "use_variables", "length_geometry_var", "length_wear_var",
                 "radius_geometry_var", "radius_wear_var", "max_offset", "work_var",
                 "extended_work_var", "rotation_var", "radius_as_diameter", "comment"},
                cw);
    c.kind = ControllerConfig::Kind::kFanucStyle;
    c.map = kind == "fanuc" ? nc::FanucMap() : kind == "haas" ? nc::HaasMap() : nc::SyntecMap();
    c.map.use_variables = r.Flag(j, "use_variables", cw);
    // Per-machine overrides of the preset's variable map (docs/HOSTD.md).
    for (auto [key, field] : {std::pair{"length_geometry_var", &nc::NcMap::length_geometry_var},
                              {"length_wear_var", &nc::NcMap::length_wear_var},
                              {"radius_geometry_var", &nc::NcMap::radius_geometry_var},
                              {"radius_wear_var", &nc::NcMap::radius_wear_var},
                              {"max_offset", &nc::NcMap::max_offset},
                              {"work_var", &nc::NcMap::work_var},
                              {"extended_work_var", &nc::NcMap::extended_work_var},
                              {"rotation_var", &nc::NcMap::rotation_var}}) {
      if (j.contains(key)) c.map.*field = jf::Integer<ConfigError>(j, key, r.Where(cw));
    }
    if (j.contains("radius_as_diameter"))
      c.map.radius_as_diameter = r.Flag(j, "radius_as_diameter", cw);
  } else if (kind == "files") {
    r.OnlyKnown(j, {"kind", "result_dir", "comment"}, cw);
    c.kind = ControllerConfig::Kind::kFiles;
  } else {
    r.Fail(cw + ".kind", "must be linuxcnc, fanuc, haas, syntec or files, not \"" + kind + "\"");
  }
  return c;
}

std::string ThisHostName() {
  char name[256] = {};
  if (gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "mlp-host";
  return name;
}

// Names that go into topic levels must be valid ones: checked here, where the file can be named.
void CheckTopicNames(const Reader& r, const HostdConfig& c) {
  const auto level = [&](const std::string& name, const std::string& field) {
    try {
      plant::CheckTopicLevel(name, field);
    } catch (const plant::MqttError& e) {
      throw ConfigError(r.Where(field) + ": " + e.what() + " (the MQTT feed puts it in topics)");
    }
  };
  level(c.host_id, "host_id");
  std::string prefix = c.mqtt->topic_prefix;  // levels joined by '/'
  for (std::size_t at = 0; at != std::string::npos;) {
    const std::size_t slash = prefix.find('/', at);
    level(prefix.substr(at, slash == std::string::npos ? slash : slash - at), "mqtt.topic_prefix");
    at = slash == std::string::npos ? slash : slash + 1;
  }
  for (const ProbeEntry& p : c.probes) level(p.serial, "probes[].serial");
  for (const MachineConfig& m : c.machines) level(m.name, "machines[].name");
}

MqttConfig ParseMqtt(const Reader& r, const json& j) {
  const std::string w = "mqtt";
  r.OnlyKnown(j,
              {"host", "port", "topic_prefix", "username", "password_file", "tls",
               "status_period_s", "keepalive_s", "max_queued", "comment"},
              w);
  const auto integer = [&](const char* key, int fallback) {
    return j.contains(key) ? jf::Integer<ConfigError>(j, key, r.Where(w)) : fallback;
  };
  MqttConfig c;
  c.host = jf::Text<ConfigError>(j, "host", r.Where(w));
  if (c.host.empty()) r.Fail("mqtt.host", "must not be empty");
  c.port = integer("port", c.port);
  if (c.port < 1 || c.port > 65535) r.Fail("mqtt.port", "must be 1..65535");
  if (j.contains("topic_prefix"))
    c.topic_prefix = jf::Text<ConfigError>(j, "topic_prefix", r.Where(w));
  if (j.contains("username")) c.username = jf::Text<ConfigError>(j, "username", r.Where(w));
  if (j.contains("password_file")) c.password_file = r.Path(j, "password_file", w);
  if (c.username.empty() != c.password_file.empty())
    r.Fail("mqtt", "needs both username and password_file, or neither");
  if (j.contains("tls")) {
    const json& t = jf::Object<ConfigError>(j, "tls", r.Where(w));
    r.OnlyKnown(t, {"ca_file", "cert_file", "key_file", "comment"}, "mqtt.tls");
    c.ca_file = r.Path(t, "ca_file", "mqtt.tls");
    if (t.contains("cert_file") || t.contains("key_file")) {
      c.cert_file = r.Path(t, "cert_file", "mqtt.tls");
      c.key_file = r.Path(t, "key_file", "mqtt.tls");
    }
  }
  c.status_period_s = r.Seconds(j, "status_period_s", c.status_period_s, w);
  // 1e-9 s was taken: 33,000 retained publishes in 3 s (issue 48).
  if (c.status_period_s < 0.1) r.Fail("mqtt.status_period_s", "must be at least 0.1 s");
  c.keepalive_s = integer("keepalive_s", c.keepalive_s);
  if (c.keepalive_s < 5 || c.keepalive_s > 3600) r.Fail("mqtt.keepalive_s", "must be 5..3600");
  c.max_queued = integer("max_queued", c.max_queued);
  if (c.max_queued < 1 || c.max_queued > 1000000) r.Fail("mqtt.max_queued", "must be 1..1000000");
  return c;
}

std::vector<ProbeEntry> ParseProbes(const Reader& r, const json& j) {
  if (!j.contains("probes") || !j.at("probes").is_array() || j.at("probes").empty())
    r.Fail("probes", "must list at least one probe");
  std::vector<ProbeEntry> probes;
  std::set<std::string> serials;
  for (size_t i = 0; i < j.at("probes").size(); ++i) {
    const std::string w = "probes[" + std::to_string(i) + "]";
    const json& p = j.at("probes")[i];
    if (!p.is_object()) r.Fail(w, "must be an object");
    r.OnlyKnown(p, {"serial", "key_file", "model_file", "comment"}, w);
    ProbeEntry e{jf::Text<ConfigError>(p, "serial", r.Where(w)), r.Path(p, "key_file", w), ""};
    if (p.contains("model_file")) e.model_file = r.Path(p, "model_file", w);
    if (!serials.insert(e.serial).second) r.Fail(w + ".serial", "is listed twice");
    probes.push_back(e);
  }
  return probes;
}

// The name is a file name (reports/<machine>-job<N>.svg, <machine>-job<N>.json): a name
// "../../../escaped" wrote outside the data folder (issue 48).
bool IsMachineFileName(const std::string& name) {
  return !name.empty() && name.size() <= 64 && name[0] != '.' &&
         std::none_of(name.begin(), name.end(), [](char ch) {
           return ch == '/' || ch == '\\' || std::iscntrl(static_cast<unsigned char>(ch));
         });
}

MachineConfig ParseMachine(const Reader& r,
                           const json& m,
                           const std::string& w,
                           const std::set<std::string>& serials) {
  if (!m.is_object()) r.Fail(w, "must be an object");
  r.OnlyKnown(m, {"name", "probe", "controller", "limits", "job_timeout_s", "comment"}, w);
  MachineConfig mc;
  mc.name = jf::Text<ConfigError>(m, "name", r.Where(w));
  if (!IsMachineFileName(mc.name))
    r.Fail(w + ".name",
           "must be 1 to 64 characters without '/', '\\' or control characters, not starting "
           "with '.': it names the machine's files");
  mc.probe_serial = jf::Text<ConfigError>(m, "probe", r.Where(w));
  if (!serials.count(mc.probe_serial))
    r.Fail(w + ".probe", "\"" + mc.probe_serial + "\" is not one of the probes");
  mc.controller = ParseController(r, m, w);
  mc.limits = ParseLimits(r, m, w);
  mc.job_timeout_s = r.Seconds(m, "job_timeout_s", mc.job_timeout_s, w);
  return mc;
}

}  // namespace

const MachineConfig* HostdConfig::Machine(const std::string& name) const {
  for (const auto& m : machines)
    if (m.name == name) return &m;
  return nullptr;
}

HostdConfig ParseHostdConfig(const std::string& text, const std::string& path) {
  const Reader r{path, fs::absolute(path).parent_path()};
  const json j = jf::ParseDocument<ConfigError>(text, kFormat, path);
  r.OnlyKnown(j,
              {"format", "comment", "data_dir", "job_socket", "capture_timeout_s",
               "max_rejected_stripe_share", "probe_link", "probes", "machines", "host_id", "mqtt",
               "plant_database"},
              "config");
  HostdConfig c;
  c.path = path;
  c.data_dir = r.Path(j, "data_dir", "config");
  c.job_socket = r.Path(j, "job_socket", "config");
  c.capture_timeout_s = r.Seconds(j, "capture_timeout_s", c.capture_timeout_s, "config");
  c.max_rejected_stripe_share = jf::NumberOr<ConfigError>(
      j, "max_rejected_stripe_share", c.max_rejected_stripe_share, r.Where("config"));
  if (!(c.max_rejected_stripe_share >= 0.0 && c.max_rejected_stripe_share <= 1.0))
    throw ConfigError(r.Where("config") + ".max_rejected_stripe_share: must be 0..1");
  const json& link = jf::Object<ConfigError>(j, "probe_link", r.Where("config"));
  r.OnlyKnown(link, {"address", "port", "comment"}, "probe_link");
  c.link_address = jf::Text<ConfigError>(link, "address", r.Where("probe_link"));
  const int port = jf::Integer<ConfigError>(link, "port", r.Where("probe_link"));
  if (port < 1 || port > 65535) r.Fail("probe_link.port", "must be 1..65535");
  c.link_port = static_cast<std::uint16_t>(port);
  c.probes = ParseProbes(r, j);
  std::set<std::string> serials, names;
  for (const ProbeEntry& p : c.probes) serials.insert(p.serial);
  if (!j.contains("machines") || !j.at("machines").is_array() || j.at("machines").empty())
    r.Fail("machines", "must list at least one machine");
  for (size_t i = 0; i < j.at("machines").size(); ++i) {
    const std::string w = "machines[" + std::to_string(i) + "]";
    c.machines.push_back(ParseMachine(r, j.at("machines")[i], w, serials));
    if (!names.insert(c.machines.back().name).second) r.Fail(w + ".name", "is listed twice");
  }
  c.host_id = j.contains("host_id") ? jf::Text<ConfigError>(j, "host_id", r.Where("config"))
                                    : ThisHostName();
  if (c.host_id.empty() || c.host_id.size() > 64) r.Fail("host_id", "must be 1 to 64 characters");
  if (j.contains("plant_database")) {
    const json& d = jf::Object<ConfigError>(j, "plant_database", r.Where("config"));
    r.OnlyKnown(d, {"connection", "comment"}, "plant_database");
    c.plant_database =
        PlantDatabaseConfig{jf::Text<ConfigError>(d, "connection", r.Where("plant_database"))};
    if (c.plant_database->connection.empty())
      r.Fail("plant_database.connection", "must not be empty");
  }
  if (j.contains("mqtt")) {
    c.mqtt = ParseMqtt(r, jf::Object<ConfigError>(j, "mqtt", r.Where("config")));
    CheckTopicNames(r, c);
  }
  return c;
}

HostdConfig LoadHostdConfig(const std::string& path) {
  return ParseHostdConfig(base::ReadFileAs<ConfigError>(path, "the configuration: "), path);
}

}  // namespace mlp::service
