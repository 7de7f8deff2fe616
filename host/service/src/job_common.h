#pragma once
// What the host's jobs share (internal to mlp_service): the job context, request parsing of
// common parts, and the stored captures mapped into the machine frame.

#include "mlp/base/input_error.h"
#include "mlp/calib/record.h"
#include "mlp/features/edge.h"
#include "mlp/features/feature.h"
#include "mlp/geometry/types.h"
#include "mlp/history/history.h"
#include "mlp/jobs/evidence.h"
#include "mlp/jobs/readings.h"
#include "mlp/nc/nc_output.h"
#include "mlp/service/config.h"
#include "mlp/service/job_server.h"
#include "mlp/toolcam/tool_model.h"

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "plant_feed.h"
#include <nlohmann/json.hpp>

namespace mlp::service {

struct JobContext {
  const HostdConfig& config;
  const MachineConfig& machine;
  history::History& history;
  Log log;
  PlantFeed& feed;  ///< the plant's live feed (does nothing without a broker configured)
};

/// A request that cannot be carried out as written: the message names the field.
class JobInputError : public base::InputError {
 public:
  using base::InputError::InputError;
};

using Clock = std::chrono::steady_clock;
double Ms(Clock::time_point since);
/// Hours since an ISO 8601 UTC time; unreadable times count as very old.
double AgeHours(const std::string& utc);

/// One job's life in the history: started with the probe's latest calibration on
/// construction, closed once by Finish or Fail with the reply.
struct JobRun {
  JobRun(JobContext& ctx, const std::string& kind, const nlohmann::json& request);
  /// Throws JobInputError when the probe has no calibration.
  const calib::CalibrationRecord& Calibration() const;
  nlohmann::json Finish(history::JobStatus status, bool ok);
  /// Logs the reason and closes the job as failed.
  nlohmann::json Fail(const std::exception& e);
  /// Closes the job as refused, `problems` in the reply (the first as its error), nothing
  /// written.
  nlohmann::json Refuse(const std::vector<std::string>& problems);
  /// Writes `out` through the machine's adapter (WriteToController) and closes the job as done.
  nlohmann::json WriteAndFinish(const nc::NcResult& out);

  JobContext& ctx;
  std::string kind;
  Clock::time_point started = Clock::now();
  std::optional<calib::CalibrationRecord> calibration;
  std::int64_t job = 0;
  nlohmann::json reply;
};

/// {"top_centre_mm", "axis" (default +Z), "diameter_mm", "depth_mm", "band_mm"}.
features::BoreNominal ParseBoreNominal(const nlohmann::json& n, const std::string& where);
/// A face's nominal: point_mm, normal, band_mm, within_mm.
features::PlaneNominal ParsePlaneNominal(const nlohmann::json& n, const std::string& where);
inline nlohmann::json JsonVec(const geometry::Vec3& v) { return {v.x(), v.y(), v.z()}; }
/// A job's readings as the reply's JSON object (a vector as [x, y, z], a group as an object, a
/// list of groups as an array of objects).
nlohmann::json ReadingsJson(const jobs::Readings& readings);

/// A capture named in a request (rather than given by job id) is used only this soon after it
/// was taken: the macro takes its captures and then measures.
constexpr int kNamedCaptureMaxAgeS = 3600;

/// The points a job measures, mapped into the machine frame (mlp::jobs).
using Evidence = jobs::Evidence;

/// A stored capture: its cloud in the probe frame and the flange pose H it was taken at.
struct StoredCapture {
  std::string id, probe_serial;
  geometry::Pose3 mcs_from_flange = geometry::Pose3::Identity();
  geometry::Points3 points_in_probe;
  std::optional<base::EdgeSight> edge;  ///< the LED frame's edge of an edge ROI
  /// The pose as the capture request gave it: H, and on a trunnion the joints, the frame and
  /// the kinematics' pins M101 read with it.
  nlohmann::json pose;
};

/// Requests longer than this (as JSON text) are kept in the history by size and SHA-256 only.
constexpr std::size_t kMaxStoredRequestBytes = 64u << 10;

/// The request as the history keeps it: whole up to kMaxStoredRequestBytes; a larger one by
/// its op, machine, request_id, size and SHA-256 (51 failing 1 MiB requests in 2 s filled a
/// 64 MB data disk and real jobs were then refused, issue 48). A repeat is recognised by this
/// form's text (RepeatsStoredRequest).
nlohmann::json StoredRequest(const nlohmann::json& request);

/// True when `request` is the one stored as `stored_text` (the history's JSON text of its
/// StoredRequest): the same body, byte for byte as JSON, not only the same request_id.
bool RepeatsStoredRequest(const nlohmann::json& request, const std::string& stored_text);

/// The tool changes history rows announced (their typed columns, absolute changes only; work
/// offsets and incremental changes are left out): how an interrupted or
/// failed write is settled against the tool table whatever the job kind.
std::vector<nc::ToolOffsetChange> ToolChangesOf(const std::vector<history::OffsetWriteRow>& rows);

/// What one job may read of the stored captures (issue 48): at most this many captures...
constexpr std::size_t kMaxCapturesPerJob = 256;
/// ... holding at most this many points together: two clouds at the link's largest
/// (link::kMaxCloudPoints), 384 MB as machine coordinates, twice that while they are gathered.
constexpr std::int64_t kMaxJobPoints = std::int64_t{16} << 20;

/// The clouds of earlier capture jobs (`capture_jobs`: ids) on this machine, each checked
/// against the SHA-256 the history holds, recorded as this job's captures. Throws
/// JobInputError.
std::vector<StoredCapture> LoadStoredCaptures(JobContext& ctx,
                                              const nlohmann::json& capture_jobs,
                                              std::int64_t job);

/// The clouds of earlier capture jobs (`capture_jobs`: ids) on this machine, each checked
/// against the SHA-256 the history holds, mapped into the machine frame with its H and the
/// calibration's M, and recorded as this job's captures. Throws JobInputError.
/// With `fitted_kinematics`, each H recomputed through a trunnion's fitted axes first
/// (UseFittedKinematics).
Evidence LoadCaptures(JobContext& ctx,
                      const nlohmann::json& capture_jobs,
                      const geometry::Pose3& flange_from_probe,
                      std::int64_t job,
                      bool fitted_kinematics = false);

/// The request's "kinematics": "controller" (default: each capture's H as it came) or "fitted"
/// (true: through a trunnion's axes as its latest kinematics job found them); JobInputError
/// for anything else.
bool FittedKinematics(const nlohmann::json& request);

/// The job's changes to the controller, made safe against a stop at any moment: announced in
/// the history first (durably, with the reply so far), then written (WriteResult), then
/// confirmed. `rows`: the offsets changed (their adapter is filled in here). Returns the files.
std::vector<std::string> WriteToController(JobContext& ctx,
                                           std::int64_t job,
                                           const nc::NcResult& out,
                                           const nlohmann::json& reply,
                                           std::vector<history::OffsetWriteRow> rows);

/// A request's idempotency key ("request_id": 1 to 128 printable ASCII characters), or "".
/// Throws JobInputError for a malformed one.
std::string RequestId(const nlohmann::json& request);

/// Throws JobInputError unless `name` can be a file name of the host's own (a capture's name):
/// 1 to 64 of A-Z a-z 0-9 . _ -, not starting with a dot. Nothing a client sends may lead a
/// file outside its folder.
void CheckSafeName(const std::string& name, const std::string& field);

/// The text of a file a request names (relative to `data_dir`, and inside it after symbolic
/// links are resolved), at most `max_bytes`, a regular file only (a FIFO or device would block
/// or never end). Throws JobInputError naming `field`.
std::string ReadDataFile(const std::string& data_dir,
                         const std::string& name,
                         const std::string& field,
                         std::size_t max_bytes);

/// The folder a request names (relative to `data_dir`, and inside it after symbolic links are
/// resolved), its real path. Throws JobInputError naming `field`.
std::string DataFolder(const std::string& data_dir,
                       const std::string& name,
                       const std::string& field);

/// The history's record of each change a job's controller result makes, announced before it is
/// written (WriteToController fills in the adapter).
std::vector<history::OffsetWriteRow> OffsetWriteRows(const nc::NcResult& out);

/// `{"op": "measure", ...}` and `{"op": "align", ...}` (docs/HOSTD.md). Always answer; the
/// status says how the job ended. Nothing reaches the controller unless every check passed.
nlohmann::json RunMeasureJob(JobContext& ctx, const nlohmann::json& request);
nlohmann::json RunPlanJob(JobContext& ctx, const nlohmann::json& request);
nlohmann::json RunAlignJob(JobContext& ctx, const nlohmann::json& request);
/// `{"op": "calibrate", ...}` (sphere hand-eye) and `{"op": "recheck", ...}` (seed 002).
nlohmann::json RunCalibrateJob(JobContext& ctx, const nlohmann::json& request);
nlohmann::json RunRecheckJob(JobContext& ctx, const nlohmann::json& request);
/// `{"op": "tool", ...}`: a tool measured from the tool camera's images (seed 000) and its
/// length and diameter written to the tool table through the machine's adapter.
nlohmann::json RunToolJob(JobContext& ctx, const nlohmann::json& request);
/// A tool's description (`mlprobe-tool/1`) named in a request, from the data folder; throws
/// JobInputError naming `field`.
toolcam::ToolDescription ReadToolDescription(const JobContext& ctx,
                                             const std::string& file,
                                             const std::string& field);
/// `{"op": "relocate", ...}` (relocate_job.cc): an EDM electrode re-clamped, its offsets.
nlohmann::json RunRelocateJob(JobContext& ctx, const nlohmann::json& request);
/// {"op": "kinematics"}: a trunnion's rotary axes from sphere captures (issue 54).
nlohmann::json RunKinematicsJob(JobContext& ctx, const nlohmann::json& request);
/// Each capture's H recomputed from its joints through the trunnion's axes as the machine's
/// latest kinematics job fitted them (their squareness too, which the controller's pins cannot
/// hold), instead of the H the controller's kinematics gave. Throws JobInputError when the
/// machine has no fitted kinematics or a capture carries no joints.
void UseFittedKinematics(const JobContext& ctx, std::vector<StoredCapture>* captures);

}  // namespace mlp::service
