// The job history on a real SQLite file: a job's whole record, listing and export, refusals,
// jobs left running by a host that stopped, and a file from a newer program.

#include "mlp/history/history.h"

#include "mlp/history/file_hash.h"

#include <array>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <thread>

#include <SQLiteCpp/SQLiteCpp.h>
#include <gtest/gtest.h>

namespace mlp::history {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

fs::path FreshDb(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "mlp_history_test";
  fs::create_directories(dir);
  const fs::path p = dir / (name + ".sqlite");
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(p.string() + suffix);
  return p;
}

JobStart Bore(const std::string& machine) {
  return {machine, "measure", "MLP-1", "MLP-1-he-7", json{{"feature", "bore"}, {"nominal", 60}}};
}

TEST(History, AJobsWholeRecordSurvivesReopening) {
  const fs::path db = FreshDb("record");
  std::int64_t id = 0;
  {
    History h(db.string());
    id = h.StartJob(Bore("vmc-1"));
    h.AddCapture(id, {"c1", json{{"translation_mm", {1, 2, 3}}}, "/data/c1.ply", "ab12", 50000});
    h.AddResult(id, {"bore B1", json{{"diameter_mm", 59.994}, {"rms_mm", 0.0012}},
                     json{{"verdict", "out of tolerance"}, {"offset_change_mm", -0.003}}});
    h.AddOffsetWrite(id, {"linuxcnc-tool-table", "tool 12 radius", json(5.0), json(4.997)});
    h.FinishJob(id, JobStatus::kOutOfTolerance, json{{"exit", 5}}, json{{"host", 12.5}});
  }
  const History h(db.string());
  const json j = h.ExportJob(id);
  EXPECT_EQ(j.at("status"), "out_of_tolerance");
  EXPECT_EQ(j.at("request").at("nominal"), 60);
  EXPECT_EQ(j.at("captures").at(0).at("points"), 50000);
  EXPECT_EQ(j.at("results").at(0).at("fit").at("diameter_mm"), 59.994);
  EXPECT_EQ(j.at("offset_writes").at(0).at("before"), 5.0);
  EXPECT_EQ(j.at("offset_writes").at(0).at("after"), 4.997);
  EXPECT_EQ(j.at("timings_ms").at("host"), 12.5);
  EXPECT_FALSE(j.at("finished_utc").get<std::string>().empty());
  EXPECT_THROW(h.ExportJob(id + 1), HistoryError);
  // The typed read a job uses: the same row and captures as the export.
  const JobCaptures typed = h.CapturesOf(id);
  EXPECT_EQ(typed.job.id, id);
  EXPECT_EQ(typed.job.kind, "measure");
  EXPECT_EQ(typed.job.machine, "vmc-1");
  EXPECT_EQ(typed.job.status, JobStatus::kOutOfTolerance);
  ASSERT_EQ(typed.captures.size(), 1u);
  EXPECT_EQ(typed.captures[0].capture_id, "c1");
  EXPECT_EQ(typed.captures[0].pose, j.at("captures").at(0).at("pose"));
  EXPECT_EQ(typed.captures[0].cloud_path, "/data/c1.ply");
  EXPECT_EQ(typed.captures[0].cloud_sha256, "ab12");
  EXPECT_EQ(typed.captures[0].points, 50000);
  EXPECT_THROW(h.CapturesOf(id + 1), HistoryError);
}

TEST(History, ClosedJobsTakeNoMoreRows) {
  const fs::path db = FreshDb("closed");
  History h(db.string());
  const auto id = h.StartJob(Bore("vmc-1"));
  h.FinishJob(id, JobStatus::kInTolerance, json::object(), json::object());
  EXPECT_THROW(h.FinishJob(id, JobStatus::kFailed, json::object(), json::object()), HistoryError);
  EXPECT_THROW(h.AddOffsetWrite(id, {"a", "G54", json(0), json(1)}), HistoryError);
  EXPECT_THROW(h.AddCapture(id + 7, {"c", json::object(), "p", "h", 1}), HistoryError);
  const auto id2 = h.StartJob(Bore("vmc-1"));
  EXPECT_THROW(h.FinishJob(id2, JobStatus::kRunning, json::object(), json::object()), HistoryError);
  EXPECT_EQ(h.ExportJob(id).at("offset_writes").size(), 0u);
}

TEST(History, ListsFiltersAndExportsCsv) {
  const fs::path db = FreshDb("list");
  History h(db.string());
  const auto a = h.StartJob(Bore("vmc-1"));
  const auto b = h.StartJob({"vmc-2", "align", "MLP-1", "MLP-1-he-7", json::object()});
  const auto c = h.StartJob({"vmc,\"3\"", "measure", "MLP-2", "", json::object()});
  h.FinishJob(a, JobStatus::kInTolerance, json::object(), json::object());
  h.FinishJob(b, JobStatus::kRefused, json::object(), json::object());
  EXPECT_EQ(h.ListJobs({}).size(), 3u);
  JobFilter f;
  f.machine = "vmc-2";
  ASSERT_EQ(h.ListJobs(f).size(), 1u);
  EXPECT_EQ(h.ListJobs(f)[0].status, JobStatus::kRefused);
  f = {};
  f.kind = "measure";
  EXPECT_EQ(h.ListJobs(f).size(), 2u);
  f = {};
  f.since_utc = "2999-01-01T00:00:00.000Z";
  EXPECT_TRUE(h.ListJobs(f).empty());
  const std::string csv = JobsCsv(h.ListJobs({}));
  EXPECT_EQ(csv.substr(0, csv.find("\r\n")),
            "id,machine,kind,probe_serial,calibration_id,status,started_utc,finished_utc");
  EXPECT_NE(csv.find(std::to_string(c) + ",\"vmc,\"\"3\"\"\",measure,MLP-2,,running,"),
            std::string::npos)
      << csv;
}

// The SPC view's query: a feature's results of jobs that measured, newest N, oldest first;
// refused and failed jobs and other machines' left out.
TEST(History, AFeaturesResultsForSpc) {
  History h(FreshDb("spc").string());
  std::vector<std::int64_t> measured;
  for (int i = 0; i < 6; ++i) {
    const std::string machine = i == 4 ? "vmc-2" : "vmc-1";
    const auto id = h.StartJob(Bore(machine));
    h.AddResult(id, {"bore", json{{"size_mm", 60.0 + 0.001 * i}}, json::object()});
    const JobStatus st = i == 2   ? JobStatus::kRefused
                         : i == 3 ? JobStatus::kOutOfTolerance
                                  : JobStatus::kInTolerance;
    h.FinishJob(id, st, json::object(), json::object());
    if (st != JobStatus::kRefused && machine == "vmc-1") measured.push_back(id);
  }
  const auto face = h.StartJob(Bore("vmc-1"));
  h.AddResult(face, {"face", json{{"size_mm", 1.0}}, json::object()});
  h.FinishJob(face, JobStatus::kInTolerance, json::object(), json::object());
  const auto all = h.FeatureResults({"bore", std::string("vmc-1"), 50});
  ASSERT_EQ(all.size(), measured.size());
  for (size_t k = 0; k < all.size(); ++k) EXPECT_EQ(all[k].job, measured[k]);  // oldest first
  EXPECT_EQ(all.back().status, JobStatus::kInTolerance);
  EXPECT_EQ(all.front().request.at("feature"), "bore");
  const auto last2 = h.FeatureResults({"bore", std::string("vmc-1"), 2});
  ASSERT_EQ(last2.size(), 2u);
  EXPECT_EQ(last2[1].job, measured.back());
  EXPECT_EQ(h.FeatureResults({"bore", std::nullopt, 50}).size(), measured.size() + 1);
  EXPECT_TRUE(h.FeatureResults({"slot", std::nullopt, 50}).empty());
}

// mlp-hostd runs one job per machine at once, on one History: two machines' jobs write at the
// same moment. Each call is its own transaction; none may fail for the other's, nor mix rows.
TEST(History, TwoMachinesJobsWriteAtOnce) {
  History h(FreshDb("concurrent").string());
  constexpr int kJobsPerMachine = 150;
  std::atomic<int> failures{0};
  const auto machine = [&](const std::string& name) {
    for (int k = 0; k < kJobsPerMachine; ++k) {
      try {
        const std::int64_t job = h.StartJob(Bore(name));
        h.AddResult(job, {"bore", {{"size_mm", 60.0 + k * 1e-4}}, {{"ok", true}}});
        h.AddWriteIntents(job, {{"lcnc", "tool 12", {{"mm", 1}}, {{"mm", 2}}, "intent"}},
                          {{"job_id", job}});
        h.MarkWritesDone(job);
        h.FinishJob(job, JobStatus::kInTolerance, {{"job_id", job}}, {});
      } catch (const HistoryError&) {
        ++failures;
      }
    }
  };
  std::thread a(machine, "vmc-1"), b(machine, "vmc-2");
  a.join(), b.join();
  EXPECT_EQ(failures.load(), 0);
  JobFilter f;
  f.limit = 10000;
  const auto jobs = h.ListJobs(f);
  ASSERT_EQ(jobs.size(), 2u * kJobsPerMachine);
  for (const auto& j : jobs) {
    EXPECT_EQ(j.status, JobStatus::kInTolerance);
    const json e = h.ExportJob(j.id);
    EXPECT_EQ(e.at("results").size(), 1u);
    EXPECT_EQ(e.at("offset_writes").size(), 1u);
  }
}

TEST(History, TheLatestCaptureOfANameWhateverItsStatus) {
  History h(FreshDb("named").string());
  auto capture = [&](const std::string& machine, const std::string& name, JobStatus status) {
    const auto id = h.StartJob({machine, "capture", "MLP-1", "", {{"capture_id", name}}});
    h.FinishJob(id, status, json::object(), json::object());
    return id;
  };
  const auto first = capture("vmc-1", "wall_0", JobStatus::kDone);
  capture("vmc-2", "wall_0", JobStatus::kDone);  // another machine's
  EXPECT_EQ(h.LatestCapture("vmc-1", "wall_0")->id, first);
  const auto failed = capture("vmc-1", "wall_0", JobStatus::kFailed);
  const auto latest = h.LatestCapture("vmc-1", "wall_0");  // the failed one: no stand-in
  EXPECT_EQ(latest->id, failed);
  EXPECT_EQ(latest->status, JobStatus::kFailed);
  EXPECT_FALSE(h.LatestCapture("vmc-1", "wall_90"));
}

TEST(History, JobsLeftRunningAreClosedOnStartUp) {
  const fs::path db = FreshDb("interrupted");
  std::int64_t id = 0;
  {
    History h(db.string());
    id = h.StartJob(Bore("vmc-1"));
  }  // the host stopped mid-job
  History h(db.string());
  EXPECT_EQ(h.CloseInterruptedJobs("host restarted mid-job"), std::vector<std::int64_t>{id});
  const json j = h.ExportJob(id);
  EXPECT_EQ(j.at("status"), "failed");
  EXPECT_EQ(j.at("reply").at("error"), "host restarted mid-job");
  EXPECT_TRUE(h.CloseInterruptedJobs("again").empty());
}

// The rows of the one job a stop left with announced writes.
std::vector<OffsetWriteRow> InterruptedRows(const fs::path& db) {
  const History h(db.string());
  const auto interrupted = h.InterruptedWrites();
  EXPECT_EQ(interrupted.size(), 1u);
  return interrupted.empty() ? std::vector<OffsetWriteRow>{} : interrupted[0].writes;
}

// Two tool changes read back typed, value for value, and a work offset's row without one.
void ExpectTyped(const std::vector<OffsetWriteRow>& rows,
                 const std::array<nc::ToolOffsetChange, 2>& expected) {
  ASSERT_EQ(rows.size(), 3u);
  for (size_t k = 0; k < 2; ++k) {
    ASSERT_TRUE(rows[k].tool.has_value()) << k;
    const nc::ToolOffsetChange& t = *rows[k].tool;
    EXPECT_EQ(t.tool, expected[k].tool);
    EXPECT_EQ(t.reg, expected[k].reg);
    EXPECT_EQ(t.before_mm, expected[k].before_mm);
    EXPECT_EQ(t.after_mm, expected[k].after_mm);
    EXPECT_EQ(t.incremental, expected[k].incremental);
  }
  EXPECT_FALSE(rows[2].tool.has_value());  // a work offset
}

// A restart settles an interrupted tool change from typed columns, never from the row's text
// (issue 53): the change read back is the one announced, whatever the job kind wrote it.
TEST(History, AnInterruptedToolChangeIsReadBackTyped) {
  const fs::path db = FreshDb("typed");
  std::int64_t id = 0;
  const nc::ToolOffsetChange radius{12, nc::ToolRegister::kRadiusGeometry, 5.0, 4.997, false};
  const nc::ToolOffsetChange wear{3, nc::ToolRegister::kLengthWear, 0.0, -0.01, true};
  {
    History h(db.string());
    id = h.StartJob(Bore("vmc-1"));
    OffsetWriteRow r{"lcnc", "offset 12 radius geometry", json(5.0), json(4.997)};
    r.tool = radius;
    OffsetWriteRow w{"fanuc", "offset 3 length wear", json(), json{{"change_mm", -0.01}}};
    w.tool = wear;
    h.AddWriteIntents(id, {r, w, {"lcnc", "G54", json(), json{{"origin_mm", {1, 2, 3}}}}},
                      json::object());
  }  // killed during the write
  ExpectTyped(InterruptedRows(db), {radius, wear});
}

// A host upgraded while a tool change of the old program (schema 2: the change only as text)
// was interrupted: the typed columns are filled in from the text once, on opening.
TEST(History, AVersionTwoFilesInterruptedToolChangeIsMigratedToTypedColumns) {
  const fs::path db = FreshDb("v2");
  {
    SQLite::Database raw(db.string(), SQLite::OPEN_READWRITE | SQLite::OPEN_CREATE);
    raw.exec(R"sql(
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
INSERT INTO meta VALUES ('schema_version', '2');
CREATE TABLE jobs (id INTEGER PRIMARY KEY, machine TEXT NOT NULL, kind TEXT NOT NULL,
  probe_serial TEXT NOT NULL, calibration_id TEXT NOT NULL, request TEXT NOT NULL,
  status TEXT NOT NULL, reply TEXT, timings_ms TEXT, started_utc TEXT NOT NULL,
  finished_utc TEXT, request_id TEXT);
CREATE TABLE offset_writes (id INTEGER PRIMARY KEY, job_id INTEGER NOT NULL REFERENCES jobs (id),
  adapter TEXT NOT NULL, target TEXT NOT NULL, before TEXT NOT NULL, after TEXT NOT NULL,
  written_utc TEXT NOT NULL, state TEXT NOT NULL DEFAULT 'written');
INSERT INTO jobs VALUES (7, 'vmc-1', 'tool', 'MLP-1', 'c', '{}', 'running', '{}', NULL,
  '2026-12-01T00:00:00Z', NULL, NULL);
INSERT INTO offset_writes VALUES (1, 7, 'lcnc', 'offset 12 length geometry', '120.5', '120.49',
  '2026-12-01T00:00:00Z', 'intent');
INSERT INTO offset_writes VALUES (2, 7, 'fanuc', 'offset 4 radius wear', 'null',
  '{"change_mm":-0.003}', '2026-12-01T00:00:00Z', 'intent');
INSERT INTO offset_writes VALUES (3, 7, 'lcnc', 'G54', 'null', '{"origin_mm":[1,2,3]}',
  '2026-12-01T00:00:00Z', 'intent');
)sql");
  }
  const nc::ToolOffsetChange length{12, nc::ToolRegister::kLengthGeometry, 120.5, 120.49, false};
  const nc::ToolOffsetChange wear{4, nc::ToolRegister::kRadiusWear, 0.0, -0.003, true};
  ExpectTyped(InterruptedRows(db), {length, wear});
}

TEST(History, RefusesAFileFromANewerProgramOrNotADatabase) {
  const fs::path db = FreshDb("newer");
  { History h(db.string()); }
  {
    SQLite::Database raw(db.string(), SQLite::OPEN_READWRITE);
    raw.exec("UPDATE meta SET value = '99' WHERE key = 'schema_version'");
  }
  try {
    History h(db.string());
    ADD_FAILURE() << "opened a newer schema";
  } catch (const HistoryError& e) {
    EXPECT_NE(std::string(e.what()).find("newer"), std::string::npos) << e.what();
  }
  const fs::path junk = FreshDb("junk");
  std::ofstream(junk) << "this is not a database, just text long enough to be read as a header";
  EXPECT_THROW(History h(junk.string()), HistoryError);
  EXPECT_THROW(History h("/nonexistent/folder/h.sqlite"), HistoryError);
}

TEST(History, HashesCloudFiles) {
  const fs::path p = fs::temp_directory_path() / "mlp_history_abc.txt";
  std::ofstream(p) << "abc";
  EXPECT_EQ(Sha256OfFile(p.string()),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");  // FIPS 180-2
  EXPECT_THROW(Sha256OfFile((p.string() + ".missing")), HistoryError);
}

}  // namespace
}  // namespace mlp::history
