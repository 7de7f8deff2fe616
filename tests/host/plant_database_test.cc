// mlp-hostd sending every finished job to the plant's PostgreSQL database (a real server the test
// starts): the job there as the host's history has it, read with `mlp history --db URI`; the
// server away while a job runs and over a restart of the host: the job waits in the history's
// outbox and arrives when the server is back. Relocate jobs: no probe needed.

#include <filesystem>
#include <fstream>

#include "electrode_site.h"
#include "plant/postgres.h"

namespace mlp::test {
namespace {

void DatabaseSite(const Site& site, const Postgres& pg) {
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["host_id"] = "cell3";
  config["plant_database"] = {{"connection", pg.Uri()}};
  ElectrodeSite(site, config);
}

// The plant database's jobs of cell3 as `mlp history --db URI --format json` lists them.
json PlantJobs(const Postgres& pg) {
  const auto r = RunProcess(kMlp + " history --db '" + pg.Uri() + "' --host cell3 --format json");
  return r.exit_code == 0 ? json::parse(r.out) : json::array();
}

bool PlantHasJob(const Postgres& pg, std::int64_t job, const std::string& status) {
  return Eventually([&] {
    for (const json& j : PlantJobs(pg))
      if (j.at("id") == job && j.at("status") == status) return true;
    return false;
  });
}

TEST(HostdPlantDatabase, EveryJobReachesThePlantAndWaitsWhileTheServerIsAway) {
  Postgres pg("hostd");
  Site site("plant_database", 17468);
  DatabaseSite(site, pg);
  if (HasFatalFailure()) return;
  auto hostd = std::make_unique<Child>(
      std::vector<std::string>{kHostd, "--config", (site.dir / "hostd.json").string()},
      site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }))
      << ReadText(site.dir / "hostd.log");

  const auto done = site.Mlp("request " + site.Request("after", RelocateJob("after")) + " --json");
  ASSERT_EQ(done.exit_code, 0) << done.err;
  const std::int64_t done_job = json::parse(done.out).at("job_id");
  ASSERT_TRUE(PlantHasJob(pg, done_job, "done")) << ReadText(site.dir / "hostd.log");
  const auto exported = RunProcess(kMlp + " history --db '" + pg.Uri() + "' --host cell3 --job " +
                                   std::to_string(done_job));
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  const json plant = json::parse(exported.out);
  EXPECT_EQ(plant.at("offset_writes").size(), 4u);  // T30's X, Y, Z, C
  json local = json::parse(RunProcess(kMlp + " history --db " +
                                      (site.dir / "data" / "history.sqlite").string() + " --job " +
                                      std::to_string(done_job))
                               .out);
  local["host"] = "cell3";
  EXPECT_EQ(plant, local);
  EXPECT_NE(site.Mlp("status").out.find("plant database: reached, 1 jobs sent, 0 waiting"),
            std::string::npos)
      << site.Mlp("status").out;

  // The server goes away: the job still runs (refused here: tilted), and waits.
  pg.Stop();
  const auto refused =
      site.Mlp("request " + site.Request("tilted", RelocateJob("tilted")) + " --json");
  EXPECT_EQ(refused.exit_code, 6) << refused.err;
  const std::int64_t refused_job = json::parse(refused.out).at("job_id");
  EXPECT_TRUE(site.WaitFor([&] {
    const json s = json::parse(site.Mlp("status --json").out).at("plant_database");
    return s.at("waiting") == 1 && s.at("connected") == false;
  })) << site.Mlp("status").out;
  // ... over a restart of the host too.
  EXPECT_EQ(hostd->Stop(), 0);
  hostd.reset();
  pg.Start();
  Child again({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd2.log");
  EXPECT_TRUE(PlantHasJob(pg, refused_job, "refused")) << ReadText(site.dir / "hostd2.log");
  EXPECT_EQ(PlantJobs(pg).size(), 2u);  // nothing twice
  EXPECT_NE(ReadText(site.dir / "hostd.log").find("jobs wait in the outbox"), std::string::npos);
}

}  // namespace
}  // namespace mlp::test
