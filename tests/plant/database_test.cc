// The plant's PostgreSQL database against a real server the test starts (tests/plant/
// postgres.h): a host's jobs sent and read back as its history has them, two hosts writing at
// once, a server that goes away and comes back, and the history's outbox that feeds it.

#include "mlp/plant/database.h"

#include <filesystem>
#include <thread>

#include "postgres.h"
#include <gtest/gtest.h>

namespace mlp::plant {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;
using history::History;
using history::JobStatus;

std::string FreshHistory(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("mlp_plantdb_" + name + ".sqlite");
  for (const char* tail : {"", "-wal", "-shm"}) fs::remove(p.string() + tail);
  return p.string();
}

// A measure job of a bore on `machine`, `size_mm` against 40 +-0.02, written to tool 12.
std::int64_t MeasureJob(History& h, const std::string& machine, double size_mm) {
  const json request = {{"op", "measure"},
                        {"feature", "bore"},
                        {"nominal", {{"diameter_mm", 40.0}}},
                        {"tolerance", {{"upper_mm", 0.02}, {"lower_mm", 0.02}}}};
  const std::int64_t job = h.StartJob({machine, "measure", "MLP-REF-0001", "cal-7", request});
  h.AddCapture(job, {"c1", {{"translation_mm", {0, 0, 100}}}, "/d/clouds/1/c1.ply", "ab12", 5000});
  h.AddResult(job, {"bore", {{"size_mm", size_mm}, {"error_mm", size_mm - 40.0}}, {{"ok", true}}});
  h.AddWriteIntents(job, {{"lcnc", "tool 12 radius", {{"mm", 4.999}}, {{"mm", 4.998}}, "intent"}},
                    {{"job_id", job}});
  h.MarkWritesDone(job);
  h.FinishJob(job, JobStatus::kInTolerance, {{"job_id", job}, {"diameter_mm", size_mm}},
              {{"total", 12.5}});
  return job;
}

TEST(PlantDatabase, AJobSentReadsBackAsItsHostsHistoryHasIt) {
  test::Postgres pg("readback");
  History h(FreshHistory("readback"));
  const std::int64_t a = MeasureJob(h, "vmc-1", 40.004), b = MeasureJob(h, "vmc-1", 40.006);
  PlantDatabase db(pg.Uri());
  for (const std::int64_t job : {a, b}) db.Send("cell3", h.ExportJob(job));
  for (const std::int64_t job : {a, b}) {
    json local = h.ExportJob(job), plant = db.ExportJob(job);
    EXPECT_EQ(plant.at("host"), "cell3");
    plant.erase("host");
    EXPECT_EQ(plant, local);  // every field, the captures', results' and offset writes' too
  }
  db.Send("cell3", h.ExportJob(a));  // sent again (a retry): replaced, not doubled
  const auto jobs = db.ListJobs({});
  ASSERT_EQ(jobs.size(), 2u);
  EXPECT_EQ(jobs[0].host, "cell3");
  EXPECT_EQ(jobs[0].id, a);
  EXPECT_EQ(jobs[1].status, JobStatus::kInTolerance);
  const auto local = h.FeatureResults({"bore", std::nullopt, 50});
  const auto plant = db.FeatureResults({"bore", std::nullopt, 50});
  ASSERT_EQ(plant.size(), local.size());
  for (size_t k = 0; k < plant.size(); ++k) {
    EXPECT_EQ(plant[k].job, local[k].job);
    EXPECT_EQ(plant[k].fit, local[k].fit);
    EXPECT_EQ(plant[k].request, local[k].request);
  }
  EXPECT_THROW(db.ExportJob(999), PlantDatabaseError);
}

TEST(PlantDatabase, TwoHostsWriteAtOnceAndNeitherLosesAJob) {
  test::Postgres pg("two_hosts");
  constexpr int kJobs = 60;
  const auto host = [&](const std::string& name) {
    History h(FreshHistory(name));
    PlantDatabase db(pg.Uri());
    for (int k = 0; k < kJobs; ++k) {
      const std::int64_t job = MeasureJob(h, name + "-vmc", 40.0 + 0.0001 * k);
      db.Send(name, h.ExportJob(job));
    }
  };
  std::thread cell3(host, "cell3"), cell4(host, "cell4");
  cell3.join(), cell4.join();
  PlantDatabase reader(pg.Uri());
  EXPECT_EQ(reader.ListJobs({}).size(), 2u * kJobs);
  history::JobFilter only;
  only.host = "cell4";
  const auto cell4_jobs = reader.ListJobs(only);
  ASSERT_EQ(cell4_jobs.size(), static_cast<size_t>(kJobs));
  for (const auto& j : cell4_jobs) EXPECT_EQ(j.machine, "cell4-vmc");
  // Both hosts numbered from 1: a bare id is ambiguous, and said so.
  try {
    reader.ExportJob(1);
    ADD_FAILURE() << "an ambiguous job id was answered";
  } catch (const PlantDatabaseError& e) {
    EXPECT_NE(std::string(e.what()).find("cell3, cell4"), std::string::npos) << e.what();
  }
  EXPECT_EQ(reader.ExportJob(1, "cell4").at("machine"), "cell4-vmc");
  EXPECT_EQ(reader.FeatureResults({"bore", "cell3-vmc", 1000}).size(), static_cast<size_t>(kJobs));
}

TEST(PlantDatabase, AServerAwayIsATypedErrorAndTheNextCallReconnects) {
  test::Postgres pg("away");
  History h(FreshHistory("away"));
  PlantDatabase db(pg.Uri());
  db.Send("cell3", h.ExportJob(MeasureJob(h, "vmc-1", 40.0)));
  pg.Stop();
  const std::int64_t job = MeasureJob(h, "vmc-1", 40.001);
  try {
    db.Send("cell3", h.ExportJob(job));
    ADD_FAILURE() << "sent to a stopped server";
  } catch (const PlantDatabaseError& e) {
    EXPECT_EQ(std::string(e.what()).find(test::Postgres::kPassword), std::string::npos);
  }
  pg.Start();
  db.Send("cell3", h.ExportJob(job));
  EXPECT_EQ(db.ListJobs({}).size(), 2u);
}

TEST(PlantDatabase, TheOutboxQueuesEveryCloseAndKeepsAJobChangedWhileItWasSent) {
  History h(FreshHistory("outbox"));
  const std::int64_t before = MeasureJob(h, "vmc-1", 40.0);
  const std::int64_t running = h.StartJob({"vmc-1", "capture", "P", "", {{"capture_id", "c"}}});
  h.EnablePlantOutbox();
  h.EnablePlantOutbox();  // idempotent: queued once
  auto queued = h.PlantOutbox(10);
  ASSERT_EQ(queued.size(), 1u);  // closed before: queued; running: not yet
  EXPECT_EQ(queued[0].job, before);
  h.FinishJob(running, JobStatus::kDone, {{"ok", true}}, {});
  queued = h.PlantOutbox(10);
  ASSERT_EQ(queued.size(), 2u);
  EXPECT_EQ(queued[1].job, running);
  h.PlantSent(queued[0]);
  // The capture is rejected after it was exported: the stale send leaves it queued.
  ASSERT_TRUE(h.RejectCapture("vmc-1", running, "the machine moved"));
  h.PlantSent(queued[1]);
  queued = h.PlantOutbox(10);
  ASSERT_EQ(queued.size(), 1u);
  EXPECT_EQ(queued[0].job, running);
  EXPECT_EQ(queued[0].version, 2);
  h.PlantSent(queued[0]);
  EXPECT_EQ(h.PlantOutboxSize(), 0);
}

}  // namespace
}  // namespace mlp::plant
