#include "mlp/history/history.h"

#include "mlp/base/clock.h"
#include "mlp/base/csv.h"
#include "mlp/base/json_text.h"

#include <algorithm>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>

#include <SQLiteCpp/SQLiteCpp.h>
#include <sys/stat.h>

namespace mlp::history {
namespace {

using json = nlohmann::json;
// 2: jobs.request_id (idempotency key), offset_writes.state (intent before the write, written
// after it), meta job_id_floor. 3: a tool register's change as typed columns of offset_writes
// (tool, tool_register, before_mm, after_mm, incremental), which a restart settles from.
constexpr int kSchemaVersion = 3;
// Another process (mlp history reading while the host writes) holds the lock briefly.
constexpr int kBusyTimeoutMs = 5000;

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS jobs (
  id INTEGER PRIMARY KEY,
  machine TEXT NOT NULL, kind TEXT NOT NULL, probe_serial TEXT NOT NULL,
  calibration_id TEXT NOT NULL, request TEXT NOT NULL, status TEXT NOT NULL,
  reply TEXT, timings_ms TEXT, started_utc TEXT NOT NULL, finished_utc TEXT, request_id TEXT);
CREATE INDEX IF NOT EXISTS jobs_started ON jobs (started_utc);
CREATE TABLE IF NOT EXISTS captures (
  id INTEGER PRIMARY KEY, job_id INTEGER NOT NULL REFERENCES jobs (id),
  capture_id TEXT NOT NULL, pose TEXT NOT NULL, cloud_path TEXT NOT NULL,
  cloud_sha256 TEXT NOT NULL, points INTEGER NOT NULL);
CREATE TABLE IF NOT EXISTS results (
  id INTEGER PRIMARY KEY, job_id INTEGER NOT NULL REFERENCES jobs (id),
  feature TEXT NOT NULL, fit TEXT NOT NULL, decision TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS offset_writes (
  id INTEGER PRIMARY KEY, job_id INTEGER NOT NULL REFERENCES jobs (id),
  adapter TEXT NOT NULL, target TEXT NOT NULL, before TEXT NOT NULL, after TEXT NOT NULL,
  written_utc TEXT NOT NULL, state TEXT NOT NULL DEFAULT 'written',
  tool INTEGER, tool_register TEXT, before_mm REAL, after_mm REAL, incremental INTEGER);
)sql";
// Version 1 files gain the columns of version 2 (a v1 offset write was recorded after it
// happened: 'written').
constexpr const char* kMigrateV1 = R"sql(
ALTER TABLE jobs ADD COLUMN request_id TEXT;
ALTER TABLE offset_writes ADD COLUMN state TEXT NOT NULL DEFAULT 'written';
)sql";
// Version 2 files gain the typed columns of version 3 (filled in by BackfillToolColumns).
constexpr const char* kMigrateV2 = R"sql(
ALTER TABLE offset_writes ADD COLUMN tool INTEGER;
ALTER TABLE offset_writes ADD COLUMN tool_register TEXT;
ALTER TABLE offset_writes ADD COLUMN before_mm REAL;
ALTER TABLE offset_writes ADD COLUMN after_mm REAL;
ALTER TABLE offset_writes ADD COLUMN incremental INTEGER;
)sql";
constexpr const char* kIndexes = R"sql(
CREATE INDEX IF NOT EXISTS jobs_request ON jobs (machine, request_id);
)sql";

[[noreturn]] void Fail(const std::string& what) { throw HistoryError(what); }

std::optional<std::pair<dev_t, ino_t>> FileIdentity(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  return std::pair{st.st_dev, st.st_ino};
}

// Stored JSON text: bytes that are not UTF-8 (quoted from a peer in an error) become U+FFFD
// rather than making the row unwritable.
std::string Text(const json& j) { return base::json_fields::DumpText(j); }

json ParseStored(const std::string& text) { return text.empty() ? json() : json::parse(text); }

// The typed tool change of a row read from column `at` on (tool, tool_register, before_mm,
// after_mm, incremental); unset for a work offset's row.
std::optional<nc::ToolOffsetChange> ToolChangeAt(SQLite::Statement& q, int at) {
  if (q.getColumn(at).isNull()) return std::nullopt;
  const auto reg = nc::ToolRegisterFrom(q.getColumn(at + 1).getString());
  if (!reg) return std::nullopt;  // not written by this program
  return nc::ToolOffsetChange{q.getColumn(at).getInt(), *reg, q.getColumn(at + 2).getDouble(),
                              q.getColumn(at + 3).getDouble(), q.getColumn(at + 4).getInt() != 0};
}

// A version 2 file's tool changes, stored then only as text: "offset 12 radius geometry" with
// the value after (a number) or {"change_mm": c} (an increment); the typed columns filled in
// from it once, so that a restart never reads the text.
void BackfillToolColumns(SQLite::Database& db) {
  SQLite::Statement q(db, "SELECT id, target, before, after FROM offset_writes WHERE tool IS NULL");
  SQLite::Statement u(db,
                      "UPDATE offset_writes SET tool = ?, tool_register = ?, before_mm = ?, "
                      "after_mm = ?, incremental = ? WHERE id = ?");
  while (q.executeStep()) {
    std::istringstream words(q.getColumn(1).getString());
    std::string offset, rest;
    int tool = 0;
    if (!(words >> offset >> tool) || offset != "offset") continue;
    std::getline(words >> std::ws, rest);
    const auto reg = nc::ToolRegisterFrom(rest);
    const json before = json::parse(q.getColumn(2).getString(), nullptr, false);
    const json after = json::parse(q.getColumn(3).getString(), nullptr, false);
    const bool incremental =
        after.is_object() && after.contains("change_mm") && after.at("change_mm").is_number();
    if (!reg || !(after.is_number() || incremental)) continue;
    u.bind(1, tool);
    u.bind(2, nc::ToString(*reg));
    u.bind(3, before.is_number() ? before.get<double>() : 0.0);
    u.bind(4, (incremental ? after.at("change_mm") : after).get<double>());
    u.bind(5, incremental ? 1 : 0);
    u.bind(6, q.getColumn(0).getInt64());
    u.exec();
    u.reset();
  }
}

}  // namespace

std::string ToString(JobStatus s) {
  switch (s) {
    case JobStatus::kRunning:
      return "running";
    case JobStatus::kDone:
      return "done";
    case JobStatus::kInTolerance:
      return "in_tolerance";
    case JobStatus::kOutOfTolerance:
      return "out_of_tolerance";
    case JobStatus::kRefused:
      return "refused";
    case JobStatus::kFailed:
      return "failed";
  }
  return "?";
}

JobStatus JobStatusFrom(const std::string& text) {
  for (JobStatus s : {JobStatus::kRunning, JobStatus::kDone, JobStatus::kInTolerance,
                      JobStatus::kOutOfTolerance, JobStatus::kRefused, JobStatus::kFailed}) {
    if (ToString(s) == text) return s;
  }
  Fail("unknown job status '" + text + "'");
}

struct History::Impl {
  // One connection serves every thread of the host (a job per machine at once): each public
  // call holds this for its whole transaction, or two machines' BEGINs would meet on the one
  // connection ("cannot start a transaction within a transaction") and mix their rows.
  // Recursive: a call may use another (StartJob checks the file).
  mutable std::recursive_mutex m;
  std::string path;
  SQLite::Database db;
  std::optional<std::pair<dev_t, ino_t>> identity;  // the file opened, to notice its removal
  explicit Impl(const std::string& p)
      : path(p), db(p, SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE, kBusyTimeoutMs) {}

  // One row for a running job, in one transaction: `bind` fills parameters 2.. (1 is the job).
  template <class Bind>
  void InsertForRunningJob(std::int64_t job, const char* sql, Bind bind) {
    try {
      SQLite::Transaction t(db);
      RequireRunning(job);
      SQLite::Statement q(db, sql);
      q.bind(1, job);
      bind(q);
      q.exec();
      t.commit();
    } catch (const SQLite::Exception& e) {
      Fail("history " + path + ": " + e.what());
    }
  }

  // One offset write row, inside the caller's transaction.
  void InsertWrite(std::int64_t job, const OffsetWriteRow& r, const std::string& state) {
    SQLite::Statement q(db,
                        "INSERT INTO offset_writes (job_id, adapter, target, before, after, "
                        "written_utc, state, tool, tool_register, before_mm, after_mm, "
                        "incremental) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)");
    q.bind(1, job);
    q.bind(2, r.adapter);
    q.bind(3, r.target);
    q.bind(4, Text(r.before));
    q.bind(5, Text(r.after));
    q.bind(6, base::UtcTimestamp());
    q.bind(7, state);
    if (r.tool) {
      q.bind(8, r.tool->tool);
      q.bind(9, nc::ToString(r.tool->reg));
      q.bind(10, r.tool->before_mm);
      q.bind(11, r.tool->after_mm);
      q.bind(12, r.tool->incremental ? 1 : 0);
    }  // else NULLs: a work offset
    q.exec();
  }

  /// Closes a running job (no-op on one already closed): its final status, reply and, unless
  /// null, timings.
  void CloseJob(std::int64_t job, JobStatus status, const json& reply, const json* timings_ms) {
    SQLite::Statement u(db,
                        "UPDATE jobs SET status = ?, reply = ?, timings_ms = COALESCE(?, "
                        "timings_ms), finished_utc = ? WHERE id = ? AND status = 'running'");
    u.bind(1, ToString(status));
    u.bind(2, Text(reply));
    if (timings_ms == nullptr)
      u.bind(3);  // keep what the job has
    else
      u.bind(3, Text(*timings_ms));
    u.bind(4, base::UtcTimestamp());
    u.bind(5, job);
    u.exec();
  }

  void RequireRunning(std::int64_t job) {
    SQLite::Statement q(db, "SELECT status FROM jobs WHERE id = ?");
    q.bind(1, job);
    if (!q.executeStep()) Fail("history: no job " + std::to_string(job));
    if (q.getColumn(0).getString() != ToString(JobStatus::kRunning))
      Fail("history: job " + std::to_string(job) + " is already closed");
  }
};

History::History(const std::string& path) {
  try {
    impl_ = std::make_unique<Impl>(path);
    impl_->db.exec("PRAGMA journal_mode = WAL");  // readers do not block the host's writes
    // In WAL mode NORMAL syncs at checkpoints, not at every commit: the file stays consistent
    // through a power cut, which may lose the last jobs' rows (SQLite docs, "WAL mode"); an
    // fsync per row would cost the job several milliseconds.
    impl_->db.exec("PRAGMA synchronous = NORMAL");
    impl_->db.exec("PRAGMA foreign_keys = ON");
    SQLite::Transaction t(impl_->db);
    impl_->db.exec(kSchema);
    SQLite::Statement q(impl_->db, "SELECT value FROM meta WHERE key = 'schema_version'");
    if (q.executeStep()) {
      const int v = std::stoi(q.getColumn(0).getString());
      if (v > kSchemaVersion)
        Fail("history " + path + ": schema version " + std::to_string(v) +
             " is newer than this program's " + std::to_string(kSchemaVersion));
      if (v == 1) impl_->db.exec(kMigrateV1);
      if (v <= 2) {
        impl_->db.exec(kMigrateV2);
        BackfillToolColumns(impl_->db);
      }
    }
    q.reset();
    impl_->db.exec("INSERT OR REPLACE INTO meta VALUES ('schema_version', '" +
                   std::to_string(kSchemaVersion) + "')");
    impl_->db.exec(kIndexes);
    t.commit();
    impl_->identity = FileIdentity(path);
  } catch (const SQLite::Exception& e) {
    Fail("history " + path + ": " + e.what());
  }
}

History::~History() = default;

void History::CheckFile() const {
  const std::lock_guard lock(impl_->m);
  if (FileIdentity(impl_->path) != impl_->identity)
    Fail("history " + impl_->path +
         " was removed or replaced while the host ran: no job is recorded, so none runs "
         "until mlp-hostd is restarted");
}

void History::SetJobIdFloor(std::int64_t floor) {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db,
                        "INSERT OR REPLACE INTO meta VALUES ('job_id_floor', "
                        "MAX(?, COALESCE((SELECT CAST(value AS INTEGER) FROM meta "
                        "WHERE key = 'job_id_floor'), 0)))");
    q.bind(1, floor);
    q.exec();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::int64_t History::StartJob(const JobStart& s) {
  const std::lock_guard lock(impl_->m);
  CheckFile();
  try {
    // The id follows the last job, and never falls below the floor: a new history in a data
    // folder that holds an earlier one's clouds and reports must not write over them.
    SQLite::Statement q(
        impl_->db,
        "INSERT INTO jobs (id, machine, kind, probe_serial, calibration_id, request, "
        "status, started_utc, request_id) VALUES (MAX(COALESCE((SELECT MAX(id) "
        "FROM jobs), 0) + 1, COALESCE((SELECT CAST(value AS INTEGER) FROM meta "
        "WHERE key = 'job_id_floor'), 1)), ?, ?, ?, ?, ?, ?, ?, ?)");
    q.bind(8, s.request_id);
    if (s.request_id.empty()) q.bind(8);
    q.bind(1, s.machine);
    q.bind(2, s.kind);
    q.bind(3, s.probe_serial);
    q.bind(4, s.calibration_id);
    q.bind(5, Text(s.request));
    q.bind(6, ToString(JobStatus::kRunning));
    q.bind(7, base::UtcTimestamp());
    q.exec();
    return impl_->db.getLastInsertRowid();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

void History::AddCapture(std::int64_t job, const CaptureRow& r) {
  const std::lock_guard lock(impl_->m);
  impl_->InsertForRunningJob(job,
                             "INSERT INTO captures (job_id, capture_id, pose, cloud_path, "
                             "cloud_sha256, points) VALUES (?, ?, ?, ?, ?, ?)",
                             [&](SQLite::Statement& q) {
                               q.bind(2, r.capture_id);
                               q.bind(3, Text(r.pose));
                               q.bind(4, r.cloud_path);
                               q.bind(5, r.cloud_sha256);
                               q.bind(6, r.points);
                             });
}

void History::AddResult(std::int64_t job, const ResultRow& r) {
  const std::lock_guard lock(impl_->m);
  impl_->InsertForRunningJob(
      job, "INSERT INTO results (job_id, feature, fit, decision) VALUES (?, ?, ?, ?)",
      [&](SQLite::Statement& q) {
        q.bind(2, r.feature);
        q.bind(3, Text(r.fit));
        q.bind(4, Text(r.decision));
      });
}

void History::AddOffsetWrite(std::int64_t job, const OffsetWriteRow& r) {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Transaction t(impl_->db);
    impl_->RequireRunning(job);
    impl_->InsertWrite(job, r, r.state);
    t.commit();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

void History::AddWriteIntents(std::int64_t job,
                              const std::vector<OffsetWriteRow>& rows,
                              const json& reply_so_far) {
  const std::lock_guard lock(impl_->m);
  CheckFile();
  try {
    // This commit must survive a power cut too: it is what tells the next start that the
    // controller may have been changed (SQLite: FULL syncs the WAL at each commit).
    impl_->db.exec("PRAGMA synchronous = FULL");
    {
      SQLite::Transaction t(impl_->db);
      impl_->RequireRunning(job);
      for (const OffsetWriteRow& r : rows) impl_->InsertWrite(job, r, "intent");
      SQLite::Statement u(impl_->db, "UPDATE jobs SET reply = ? WHERE id = ?");
      u.bind(1, Text(reply_so_far));
      u.bind(2, job);
      u.exec();
      t.commit();
    }
    impl_->db.exec("PRAGMA synchronous = NORMAL");
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

void History::MarkWritesDone(std::int64_t job, bool written) {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db,
                        written ? "UPDATE offset_writes SET state = 'written', written_utc = ? "
                                  "WHERE job_id = ? AND state = 'intent'"
                                : "UPDATE offset_writes SET state = 'not_written' "
                                  "WHERE job_id = ?2 AND state = 'intent'");
    if (written) q.bind(1, base::UtcTimestamp());
    q.bind(2, job);
    q.exec();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::vector<InterruptedWrite> History::InterruptedWrites() const {
  const std::lock_guard lock(impl_->m);
  std::vector<InterruptedWrite> out;
  try {
    SQLite::Statement q(impl_->db,
                        "SELECT id, machine, COALESCE(reply, '') FROM jobs WHERE status = "
                        "'running' AND id IN (SELECT job_id FROM offset_writes WHERE state IN "
                        "('intent', 'written')) ORDER BY id");
    while (q.executeStep()) {
      InterruptedWrite w{q.getColumn(0).getInt64(),
                         q.getColumn(1).getString(),
                         ParseStored(q.getColumn(2).getString()),
                         {},
                         true};
      SQLite::Statement r(impl_->db,
                          "SELECT adapter, target, before, after, state, tool, tool_register, "
                          "before_mm, after_mm, incremental FROM offset_writes "
                          "WHERE job_id = ? AND state IN ('intent', 'written') ORDER BY id");
      r.bind(1, w.job);
      while (r.executeStep()) {
        w.writes.push_back({r.getColumn(0).getString(), r.getColumn(1).getString(),
                            ParseStored(r.getColumn(2).getString()),
                            ParseStored(r.getColumn(3).getString()), r.getColumn(4).getString(),
                            ToolChangeAt(r, 5)});
        w.confirmed = w.confirmed && w.writes.back().state == "written";
      }
      out.push_back(std::move(w));
    }
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
  return out;
}

void History::SettleInterrupted(std::int64_t job,
                                bool written,
                                JobStatus status,
                                const json& reply) {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Transaction t(impl_->db);
    SQLite::Statement q(impl_->db,
                        "UPDATE offset_writes SET state = ? WHERE job_id = ? AND state = 'intent'");
    q.bind(1, written ? "written" : "not_written");
    q.bind(2, job);
    q.exec();
    impl_->CloseJob(job, status, reply, nullptr);
    t.commit();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::optional<EarlierRequest> History::FindRequest(const std::string& machine,
                                                   const std::string& request_id) const {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db,
                        "SELECT id, status, COALESCE(reply, ''), EXISTS (SELECT 1 FROM "
                        "offset_writes w WHERE w.job_id = jobs.id AND w.state != 'not_written'), "
                        "request FROM jobs WHERE machine = ? AND request_id = ? "
                        "ORDER BY id DESC LIMIT 1");
    q.bind(1, machine);
    q.bind(2, request_id);
    if (!q.executeStep()) return std::nullopt;
    return EarlierRequest{q.getColumn(0).getInt64(), JobStatusFrom(q.getColumn(1).getString()),
                          ParseStored(q.getColumn(2).getString()), q.getColumn(3).getInt() != 0,
                          q.getColumn(4).getString()};
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

void History::FinishJob(std::int64_t job,
                        JobStatus status,
                        const json& reply,
                        const json& timings_ms) {
  const std::lock_guard lock(impl_->m);
  if (status == JobStatus::kRunning) Fail("history: a job is finished with a final status");
  try {
    SQLite::Transaction t(impl_->db);
    impl_->RequireRunning(job);
    impl_->CloseJob(job, status, reply, &timings_ms);
    t.commit();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

bool History::RejectCapture(const std::string& machine,
                            std::int64_t job,
                            const std::string& reason) {
  const std::lock_guard lock(impl_->m);
  CheckFile();
  try {
    SQLite::Statement u(impl_->db,
                        "UPDATE jobs SET status = 'failed', reply = json_set(COALESCE(reply, "
                        "'{}'), '$.ok', json('false'), '$.status', 'failed', '$.error', ?) "
                        "WHERE id = ? AND machine = ? AND kind = 'capture' AND status = 'done'");
    u.bind(1, reason);
    u.bind(2, job);
    u.bind(3, machine);
    return u.exec() == 1;
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::vector<std::int64_t> History::CloseInterruptedJobs(const std::string& reason) {
  const std::lock_guard lock(impl_->m);
  std::vector<std::int64_t> ids;
  try {
    SQLite::Transaction t(impl_->db);
    SQLite::Statement q(impl_->db, "SELECT id FROM jobs WHERE status = 'running'");
    while (q.executeStep()) ids.push_back(q.getColumn(0).getInt64());
    SQLite::Statement u(impl_->db,
                        "UPDATE jobs SET status = 'failed', reply = ?, finished_utc = ? "
                        "WHERE status = 'running'");
    u.bind(1, Text(json{{"error", reason}}));
    u.bind(2, base::UtcTimestamp());
    u.exec();
    t.commit();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
  return ids;
}

// The outbox and its trigger: whatever closes a job (or changes a closed one) queues it in the
// same transaction, so that no path can close a job the plant never hears of.
constexpr const char* kPlantOutbox = R"sql(
CREATE TABLE IF NOT EXISTS plant_outbox (
  job_id INTEGER PRIMARY KEY REFERENCES jobs (id), version INTEGER NOT NULL);
CREATE TRIGGER IF NOT EXISTS plant_outbox_on_close AFTER UPDATE OF status, reply ON jobs
  WHEN NEW.status != 'running'
  BEGIN
    INSERT INTO plant_outbox (job_id, version) VALUES (NEW.id, 1)
      ON CONFLICT (job_id) DO UPDATE SET version = version + 1;
  END;
)sql";

void History::EnablePlantOutbox() {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Transaction t(impl_->db);
    const bool first =
        impl_->db.execAndGet("SELECT COUNT(*) FROM sqlite_master WHERE name = 'plant_outbox'")
            .getInt() == 0;
    impl_->db.exec(kPlantOutbox);
    if (first)
      impl_->db.exec(
          "INSERT INTO plant_outbox (job_id, version) SELECT id, 1 FROM jobs WHERE status != "
          "'running'");
    t.commit();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": the plant's outbox: " + e.what());
  }
}

std::vector<History::OutboxEntry> History::PlantOutbox(int limit) const {
  const std::lock_guard lock(impl_->m);
  std::vector<OutboxEntry> out;
  try {
    SQLite::Statement q(impl_->db,
                        "SELECT job_id, version FROM plant_outbox ORDER BY job_id LIMIT ?");
    q.bind(1, limit);
    while (q.executeStep()) out.push_back({q.getColumn(0).getInt64(), q.getColumn(1).getInt64()});
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": the plant's outbox: " + e.what());
  }
  return out;
}

std::int64_t History::PlantOutboxSize() const {
  const std::lock_guard lock(impl_->m);
  try {
    return impl_->db.execAndGet("SELECT COUNT(*) FROM plant_outbox").getInt64();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": the plant's outbox: " + e.what());
  }
}

void History::PlantSent(const OutboxEntry& sent) {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db, "DELETE FROM plant_outbox WHERE job_id = ? AND version = ?");
    q.bind(1, sent.job);
    q.bind(2, sent.version);
    q.exec();
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": the plant's outbox: " + e.what());
  }
}

namespace {

constexpr const char* kSummaryColumns =
    "SELECT id, machine, kind, probe_serial, calibration_id, status, started_utc, "
    "COALESCE(finished_utc, '') FROM jobs ";

JobSummary SummaryOf(SQLite::Statement& q) {
  JobSummary s;
  s.id = q.getColumn(0).getInt64();
  s.machine = q.getColumn(1).getString();
  s.kind = q.getColumn(2).getString();
  s.probe_serial = q.getColumn(3).getString();
  s.calibration_id = q.getColumn(4).getString();
  s.status = JobStatusFrom(q.getColumn(5).getString());
  s.started_utc = q.getColumn(6).getString();
  s.finished_utc = q.getColumn(7).getString();
  return s;
}

std::vector<CaptureRow> CaptureRowsOf(SQLite::Database& db, std::int64_t job) {
  std::vector<CaptureRow> out;
  SQLite::Statement c(db,
                      "SELECT capture_id, pose, cloud_path, cloud_sha256, points FROM captures "
                      "WHERE job_id = ? ORDER BY id");
  c.bind(1, job);
  while (c.executeStep())
    out.push_back({c.getColumn(0).getString(), ParseStored(c.getColumn(1).getString()),
                   c.getColumn(2).getString(), c.getColumn(3).getString(),
                   c.getColumn(4).getInt64()});
  return out;
}

}  // namespace

JobCaptures History::CapturesOf(std::int64_t job) const {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db, std::string(kSummaryColumns) + "WHERE id = ?");
    q.bind(1, job);
    if (!q.executeStep()) Fail("history: no job " + std::to_string(job));
    return {SummaryOf(q), CaptureRowsOf(impl_->db, job)};
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::vector<JobSummary> History::ListJobs(const JobFilter& f) const {
  const std::lock_guard lock(impl_->m);
  std::vector<JobSummary> out;
  try {
    SQLite::Statement q(impl_->db,
                        std::string(kSummaryColumns) +
                            "WHERE (?1 IS NULL OR machine = ?1) AND (?2 IS NULL OR kind = ?2) AND "
                            "(?3 IS NULL OR started_utc >= ?3) ORDER BY id LIMIT ?4");
    if (f.machine) q.bind(1, *f.machine);
    if (f.kind) q.bind(2, *f.kind);
    if (f.since_utc) q.bind(3, *f.since_utc);
    q.bind(4, f.limit);
    while (q.executeStep()) out.push_back(SummaryOf(q));
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
  return out;
}

std::vector<FeatureResult> History::FeatureResults(const FeatureQuery& f) const {
  const std::lock_guard lock(impl_->m);
  std::vector<FeatureResult> out;
  try {
    SQLite::Statement q(impl_->db,
                        "SELECT j.id, j.machine, j.started_utc, j.status, r.fit, j.request FROM "
                        "results r JOIN jobs j ON j.id = r.job_id WHERE r.feature = ?1 AND "
                        "(?2 IS NULL OR j.machine = ?2) AND j.kind = 'measure' AND j.status IN "
                        "('in_tolerance', 'out_of_tolerance') ORDER BY j.id DESC LIMIT ?3");
    q.bind(1, f.feature);
    if (f.machine) q.bind(2, *f.machine);
    q.bind(3, f.last);
    while (q.executeStep()) {
      FeatureResult r;
      r.job = q.getColumn(0).getInt64();
      r.machine = q.getColumn(1).getString();
      r.started_utc = q.getColumn(2).getString();
      r.status = JobStatusFrom(q.getColumn(3).getString());
      r.fit = json::parse(q.getColumn(4).getString());
      r.request = json::parse(q.getColumn(5).getString());
      out.push_back(std::move(r));
    }
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  } catch (const json::exception& e) {
    Fail("history " + impl_->path + ": a result that is not JSON: " + e.what());
  }
  std::reverse(out.begin(), out.end());
  return out;
}

std::optional<JobSummary> History::LatestCapture(const std::string& machine,
                                                 const std::string& capture_id) const {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db,
                        std::string(kSummaryColumns) +
                            "WHERE machine = ?1 AND kind = 'capture' AND "
                            "json_extract(request, '$.capture_id') = ?2 ORDER BY id DESC LIMIT 1");
    q.bind(1, machine);
    q.bind(2, capture_id);
    if (q.executeStep()) return SummaryOf(q);
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
  return std::nullopt;
}

json History::ExportJob(std::int64_t job, const std::string& /*host*/) const {
  const std::lock_guard lock(impl_->m);
  try {
    SQLite::Statement q(impl_->db,
                        "SELECT machine, kind, probe_serial, calibration_id, request, status, "
                        "COALESCE(reply, ''), COALESCE(timings_ms, ''), started_utc, "
                        "COALESCE(finished_utc, '') FROM jobs WHERE id = ?");
    q.bind(1, job);
    if (!q.executeStep()) Fail("history: no job " + std::to_string(job));
    json j = {{"id", job},
              {"machine", q.getColumn(0).getString()},
              {"kind", q.getColumn(1).getString()},
              {"probe_serial", q.getColumn(2).getString()},
              {"calibration_id", q.getColumn(3).getString()},
              {"request", ParseStored(q.getColumn(4).getString())},
              {"status", q.getColumn(5).getString()},
              {"reply", ParseStored(q.getColumn(6).getString())},
              {"timings_ms", ParseStored(q.getColumn(7).getString())},
              {"started_utc", q.getColumn(8).getString()},
              {"finished_utc", q.getColumn(9).getString()}};
    j["captures"] = json::array();
    for (const CaptureRow& c : CaptureRowsOf(impl_->db, job))
      j["captures"].push_back({{"capture_id", c.capture_id},
                               {"pose", c.pose},
                               {"cloud_path", c.cloud_path},
                               {"cloud_sha256", c.cloud_sha256},
                               {"points", c.points}});
    j["results"] = json::array();
    SQLite::Statement r(impl_->db,
                        "SELECT feature, fit, decision FROM results WHERE job_id = ? ORDER BY id");
    r.bind(1, job);
    while (r.executeStep())
      j["results"].push_back({{"feature", r.getColumn(0).getString()},
                              {"fit", ParseStored(r.getColumn(1).getString())},
                              {"decision", ParseStored(r.getColumn(2).getString())}});
    j["offset_writes"] = json::array();
    SQLite::Statement w(impl_->db,
                        "SELECT adapter, target, before, after, written_utc, state FROM "
                        "offset_writes WHERE job_id = ? ORDER BY id");
    w.bind(1, job);
    while (w.executeStep())
      j["offset_writes"].push_back({{"adapter", w.getColumn(0).getString()},
                                    {"target", w.getColumn(1).getString()},
                                    {"before", ParseStored(w.getColumn(2).getString())},
                                    {"after", ParseStored(w.getColumn(3).getString())},
                                    {"written_utc", w.getColumn(4).getString()},
                                    {"state", w.getColumn(5).getString()}});
    return j;
  } catch (const SQLite::Exception& e) {
    Fail("history " + impl_->path + ": " + e.what());
  }
}

std::string JobsCsv(const std::vector<JobSummary>& jobs) {
  const auto quote = [](const std::string& s) { return base::CsvField(s); };
  std::ostringstream out;
  out << "id,machine,kind,probe_serial,calibration_id,status,started_utc,finished_utc\r\n";
  for (const auto& j : jobs)
    out << j.id << "," << quote(j.machine) << "," << quote(j.kind) << "," << quote(j.probe_serial)
        << "," << quote(j.calibration_id) << "," << ToString(j.status) << "," << j.started_utc
        << "," << j.finished_utc << "\r\n";
  return out.str();
}

}  // namespace mlp::history
