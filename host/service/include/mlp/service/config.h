#pragma once
/// @file mlp-hostd's configuration (`mlprobe-hostd/1`, docs/HOSTD.md; example in
/// samples/hostd/hostd.json): data folder, the probe link's address, the local job socket, the
/// known probes and their key files, and per machine its probe, controller adapter, safety
/// limits and job timeout. Relative paths are relative to the configuration file's folder.

#include "mlp/base/input_error.h"
#include "mlp/features/decision.h"
#include "mlp/nc/nc_output.h"

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::service {

/// Names the file and the field.
class ConfigError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct ProbeEntry {
  std::string serial, key_file;
  std::string model_file;  ///< its camera/projector model (capture plans); "" when not given
};

struct ControllerConfig {
  enum class Kind { kLinuxCnc, kFanucStyle, kFiles };
  Kind kind = Kind::kFiles;
  std::string tool_table;  ///< LinuxCNC: the .tbl file (values before a change are read here)
  /// LinuxCNC: the host also writes the tool table file itself (atomically), for a controller
  /// that reloads it (G10 L0) or is not running; otherwise only the result subroutine's
  /// G10 L1 lines change it, when the program calls it.
  bool write_tool_table = false;
  /// LinuxCNC: the machine's axes (its [TRAJ] COORDINATES): a tool offset is written only for
  /// an axis it has (G10 L1 with a C word stops a machine without C: "Bad character 'c' used").
  std::string axes = "XYZ";
  std::string result_dir;  ///< where results go: NC subroutine / snippet, JSON and CSV
  nc::NcMap map;           ///< Fanuc-style controls
  /// LinuxCNC with xyzac-trt-kins: the HAL file whose setp lines set the trunnion's pins at
  /// start, rewritten by a kinematics calibration (""; none: a calibration is refused).
  std::string kinematics_hal;
  /// The largest change of one pin a kinematics calibration may write [mm].
  double max_pivot_change_mm = 0.2;
};

struct MachineConfig {
  std::string name, probe_serial;
  ControllerConfig controller;
  features::PlausibilityLimits limits;
  double job_timeout_s = 120.0;
};

/// The live feed to the plant's MQTT broker (docs/HOSTD.md, "Plant"); absent: no broker.
struct MqttConfig {
  std::string host;
  int port = 1883;
  std::string topic_prefix = "mlprobe";
  std::string username;
  std::string password_file;  ///< read, and its owner-only mode checked, when the host starts
  std::string ca_file, cert_file, key_file;  ///< TLS when ca_file is given
  double status_period_s = 10.0;             ///< the retained status, refreshed this often
  int keepalive_s = 30;
  int max_queued = 10000;  ///< messages held while the broker is away
};

/// The plant's PostgreSQL database, where every finished job is also sent (docs/HOSTD.md,
/// "Plant"); absent: the local history only.
struct PlantDatabaseConfig {
  /// A libpq connection string or URI (host, port, dbname, user, sslmode, passfile, ...).
  std::string connection;
};

struct HostdConfig {
  std::string path;  ///< the file read
  /// This host's name in the plant (MQTT topics, the plant database's rows): unique there.
  /// Default: the computer's host name.
  std::string host_id;
  std::string data_dir;  ///< history.sqlite, clouds/, reports/, calibrations/
  std::string link_address = "127.0.0.1";
  std::uint16_t link_port = 7420;
  std::string job_socket;
  double capture_timeout_s = 30.0;
  /// A capture whose firmware rejected more than this share of the stripe's light (reflections,
  /// saturation, double peaks: link::StripeAccount) is refused: no job measures from it.
  double max_rejected_stripe_share = 0.5;
  std::vector<ProbeEntry> probes;
  std::vector<MachineConfig> machines;
  std::optional<MqttConfig> mqtt;
  std::optional<PlantDatabaseConfig> plant_database;

  std::string HistoryFile() const { return data_dir + "/history.sqlite"; }
  std::string CalibrationDir() const { return data_dir + "/calibrations"; }
  std::string CloudDir() const { return data_dir + "/clouds"; }
  std::string ReportDir() const { return data_dir + "/reports"; }
  /// The trunnions' axes as each machine's latest kinematics job found them (<machine>.json).
  std::string KinematicsDir() const { return data_dir + "/kinematics"; }
  const MachineConfig* Machine(const std::string& name) const;
};

/// Throws ConfigError naming the file and field. Key files are read (and their owner-only mode
/// checked) when the service starts, not here.
HostdConfig LoadHostdConfig(const std::string& path);
HostdConfig ParseHostdConfig(const std::string& json_text, const std::string& path);

}  // namespace mlp::service
