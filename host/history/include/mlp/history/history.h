#pragma once
/// @file Every job the host runs, in one SQLite file (the embedded default; SQLiteCpp over
/// sqlite3): the request, captures (cloud files by path and SHA-256), fit results with
/// residuals, decisions, offsets written with their values before and after, the calibration
/// used, timings, and how the job ended. Append-only from the jobs' side: a job row is created
/// when it starts and closed once; nothing is deleted. Each call is one transaction.

#include "mlp/nc/offsets.h"

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::history {

class HistoryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// How a job ended; "running" until FinishJob. kDone: a job without a verdict (a capture).
enum class JobStatus { kRunning, kDone, kInTolerance, kOutOfTolerance, kRefused, kFailed };
std::string ToString(JobStatus s);
JobStatus JobStatusFrom(const std::string& text);  ///< throws HistoryError

struct JobStart {
  std::string machine, kind, probe_serial, calibration_id;
  nlohmann::json request;    ///< as received
  std::string request_id{};  ///< the client's idempotency key, or empty
};

struct CaptureRow {
  std::string capture_id;
  nlohmann::json pose;  ///< mcs_from_flange as given / read from the controller
  std::string cloud_path, cloud_sha256;
  std::int64_t points = 0;
};

struct ResultRow {
  std::string feature;
  nlohmann::json fit;       ///< shape, residual RMS / max, points used
  nlohmann::json decision;  ///< verdict, error, offset change, reason
};

struct OffsetWriteRow {
  std::string adapter;  ///< "linuxcnc-tool-table", "fanuc-snippet", ...
  std::string target;   ///< "tool 12 radius wear", "G54"
  nlohmann::json before, after;
  /// "intent" (about to be written), "written", "not_written" (found so after a stop)
  std::string state = "written";
  /// A tool register's change as typed columns (schema 3): what a restart settles against the
  /// controller's tool table, whatever the job kind. Unset for work offsets.
  std::optional<nc::ToolOffsetChange> tool{};
};

/// A request seen before under the same idempotency key on the same machine.
struct EarlierRequest {
  std::int64_t job = 0;
  JobStatus status = JobStatus::kRunning;
  nlohmann::json reply;
  bool wrote = false;   ///< it wrote, or was about to write, to the controller
  std::string request;  ///< the request as stored (JobStart::request's JSON text)
};

/// A job the host left running with writes it had announced: not yet confirmed (intents), or
/// confirmed while the job itself was never closed (killed between the write and the close).
struct InterruptedWrite {
  std::int64_t job = 0;
  std::string machine;
  nlohmann::json reply;  ///< the reply as it stood before the write
  std::vector<OffsetWriteRow> writes;
  bool confirmed = false;  ///< every write already recorded as written (no intent left)
};

struct JobSummary {
  std::string host;  ///< the host it ran on: the plant database's; "" in a host's own history
  std::int64_t id = 0;
  std::string machine, kind, probe_serial, calibration_id, started_utc, finished_utc;
  JobStatus status = JobStatus::kRunning;
};

/// A job's row and the captures it recorded, typed: what a job reads back of a capture job it
/// names (its kind, status and machine decide whether it may use it).
struct JobCaptures {
  JobSummary job;
  std::vector<CaptureRow> captures;
};

/// One measured feature as the SPC view reads it: its job, where and when, the reply (the fit's
/// size and error) and the request (the tolerance).
// Its implicit move is noexcept; bugprone-exception-escape follows nlohmann::json's move into
// assert_invariant, which asserts and never throws.
struct FeatureResult {  // NOLINT(bugprone-exception-escape)
  std::string host;     ///< as JobSummary::host
  std::int64_t job = 0;
  std::string machine, started_utc;
  JobStatus status = JobStatus::kRunning;
  nlohmann::json fit, request;
};

/// The newest `last` results of `feature` (the measure job's feature kind), on `machine` if
/// given, of jobs that measured (in or out of tolerance: a refused or failed job's figures are
/// not the part's).
struct FeatureQuery {
  std::string feature;
  std::optional<std::string> machine;
  int last = 50;
};

struct JobFilter {
  std::optional<std::string> machine, kind, since_utc;  ///< since: ISO 8601, inclusive
  int limit = 1000;
  std::optional<std::string> host{};  ///< the plant database's: this host's jobs only
};

/// What `mlp history` reads, from a host's own history (History) or the plant's database
/// (mlp::plant::PlantDatabase): the same queries over the same tables.
class JobRecords {
 public:
  virtual ~JobRecords() = default;
  virtual std::vector<JobSummary> ListJobs(const JobFilter& filter) const = 0;
  /// The results FeatureQuery selects, oldest first.
  virtual std::vector<FeatureResult> FeatureResults(const FeatureQuery& query) const = 0;
  /// The whole job: its row, captures, results, offset writes. Throws HistoryError for an
  /// unknown id (or, in the plant's database, one that several hosts have and `host` does not
  /// tell apart).
  virtual nlohmann::json ExportJob(std::int64_t job, const std::string& host = "") const = 0;
};

class History : public JobRecords {
 public:
  /// Opens or creates the file (schema version 3; a newer schema is refused, an older one
  /// migrated). Throws HistoryError naming the file.
  explicit History(const std::string& path);
  ~History();
  History(const History&) = delete;
  History& operator=(const History&) = delete;

  std::int64_t StartJob(const JobStart& start);
  void AddCapture(std::int64_t job, const CaptureRow& row);
  void AddResult(std::int64_t job, const ResultRow& row);
  void AddOffsetWrite(std::int64_t job, const OffsetWriteRow& row);
  /// Closes a running job; throws HistoryError if it is not running (closed once only).
  void FinishJob(std::int64_t job,
                 JobStatus status,
                 const nlohmann::json& reply,
                 const nlohmann::json& timings_ms);
  /// The writes a job is about to make, recorded durably (synchronous commit) with its reply so
  /// far, before anything reaches the controller: a host killed during the write leaves them as
  /// intents for the next start to settle (InterruptedWrites, SettleInterrupted).
  void AddWriteIntents(std::int64_t job,
                       const std::vector<OffsetWriteRow>& rows,
                       const nlohmann::json& reply_so_far);
  /// The job's announced writes reached the controller (`written`), or a write that failed
  /// was found not to have (then a retry under the same request_id runs again).
  void MarkWritesDone(std::int64_t job, bool written = true);
  /// Marks a finished capture of `machine` failed with `reason` (the controller saw the
  /// machine move while its frames were taken): no job may use it, by id or by name, and an
  /// older capture of its name never stands in. False when `job` is no finished capture there.
  bool RejectCapture(const std::string& machine, std::int64_t job, const std::string& reason);
  /// Running jobs with announced writes (a host stopped between intent and done, or between
  /// done and the job's close).
  std::vector<InterruptedWrite> InterruptedWrites() const;
  /// Closes such a job as the controller shows it: its intents become "written" or
  /// "not_written", the job `status` with `reply`.
  void SettleInterrupted(std::int64_t job,
                         bool written,
                         JobStatus status,
                         const nlohmann::json& reply);
  /// The newest job on `machine` whose request carried `request_id`.
  std::optional<EarlierRequest> FindRequest(const std::string& machine,
                                            const std::string& request_id) const;
  /// Job ids from now on are at least `floor` (a new history in a data folder holding an
  /// earlier history's clouds and reports continues after them).
  void SetJobIdFloor(std::int64_t floor);
  /// Throws HistoryError when the file opened is no longer at its path (removed or replaced
  /// while the host ran): jobs must not run unrecorded. StartJob checks it.
  void CheckFile() const;
  /// Jobs still "running" (a host that stopped mid-job leaves them): closed as failed with
  /// `reason` on start-up; returns their ids.
  std::vector<std::int64_t> CloseInterruptedJobs(const std::string& reason);

  std::vector<JobSummary> ListJobs(const JobFilter& filter) const override;
  std::vector<FeatureResult> FeatureResults(const FeatureQuery& query) const override;
  /// The newest capture job on `machine` whose request named `capture_id`, whatever its status
  /// (a macro refers to its captures by name; a failed newest one must not let an older one
  /// stand in).
  std::optional<JobSummary> LatestCapture(const std::string& machine,
                                          const std::string& capture_id) const;
  /// The job's row and its captures in the order recorded; throws HistoryError for an unknown
  /// id. The typed read a job uses (the JSON export is for people and the plant).
  JobCaptures CapturesOf(std::int64_t job) const;
  /// `host` is ignored: a host's history is its own.
  nlohmann::json ExportJob(std::int64_t job, const std::string& host = "") const override;

  /// The plant's outbox: from now on every job closed (whatever closes it: finished, settled,
  /// a capture rejected) is queued, in the same transaction, for the plant's database; the
  /// first call also queues every job already closed. Idempotent.
  void EnablePlantOutbox();
  /// A job waiting for the plant's database; `version` counts its closes (a capture rejected
  /// after it was sent is queued again).
  struct OutboxEntry {
    std::int64_t job = 0, version = 0;
  };
  /// The oldest `limit` entries.
  std::vector<OutboxEntry> PlantOutbox(int limit) const;
  std::int64_t PlantOutboxSize() const;
  /// The entry reached the plant's database. Removed only if the job was not closed again
  /// meanwhile (then its newer state is sent next).
  void PlantSent(const OutboxEntry& sent);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Jobs as CSV (RFC 4180 quoting), one line per job with a header line.
std::string JobsCsv(const std::vector<JobSummary>& jobs);

}  // namespace mlp::history
