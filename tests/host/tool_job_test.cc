// The tool camera's results reach the LinuxCNC tool table through the host's one adapter (issue
// 20): mlp-hostd's tool job reads the images a client names in its data folder, measures the
// tool (toolcam), and writes its length and diameter as every job does: announced in the
// history, within the machine's limit, the table replaced whole, logged before and after. A
// worn tool beyond its wear limit, a folder outside the data folder, a manifest naming files
// elsewhere: refused, nothing written. Real processes: mlp tool render, mlp-hostd, mlp request.

#include "mlp/history/history.h"

#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <thread>
#include <tuple>

#include "hostd_site.h"
#include "tool_site.h"

namespace mlp::test {
namespace {

constexpr int kToolJobPort = 17461;     // the probe link's port, unused: no probe here
constexpr int kToolKillPort = 17474;    // the kill test's (no probe: unused)
constexpr double kLengthTolMm = 0.001;  // the virtual camera's tool through the job
constexpr double kDiameterTolMm = 0.002;
constexpr double kAxisTolMm = 0.0005;      // the spindle axis across a camera's view (tool_kinds')
constexpr double kPretravelTolMm = 0.001;  // the touch probe's trigger through the job
const std::string kTable = kToolT3 +
                           "T12 P12 Z101.2 D9.998 ;finishing end mill\n"
                           "T98 P98 Z60.005 D2.0 ;touch probe\n"
                           "T30 P30 Z60.0 D11.662 ;EDM electrode 10x6\n"
                           "T21 P21 Z45.1 D2.01 ;D2 end mill\n";

TEST(ToolJob, TheToolCamerasResultGoesThroughTheAdapterOrIsRefused) {
  Site site("tool_job", kToolJobPort);
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["machines"][1]["controller"]["write_tool_table"] = true;
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  std::ofstream(site.dir / "tool.tbl") << kTable;
  EndMillImages(site);
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }))
      << ReadText(site.dir / "hostd.log");

  // The new tool: measured and written, T3's Z and D, the rest of the table kept.
  const auto run =
      site.Mlp("request " + site.Request("tool-new", ToolJob("tools/new")) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const json reply = json::parse(run.out);
  std::printf("tool job: length %.5f mm, diameter %.5f mm\n",
              reply.at("update").at("length_after_mm").get<double>(),
              reply.at("update").at("diameter_after_mm").get<double>());
  EXPECT_NEAR(reply.at("update").at("length_before_mm").get<double>(), 75.1, 1e-9);
  EXPECT_NEAR(reply.at("update").at("length_after_mm").get<double>(), 75.0, kLengthTolMm);
  EXPECT_NEAR(reply.at("update").at("diameter_after_mm").get<double>(), 10.0, kDiameterTolMm);
  EXPECT_EQ(reply.at("flutes").size(), 4u);
  const std::string table = ReadText(site.dir / "tool.tbl");
  EXPECT_EQ(table.find("Z+75.100000"), std::string::npos) << table;
  EXPECT_NE(table.find(";D10 Z4 roughing"), std::string::npos) << table;
  EXPECT_NE(table.find("T12 P12 Z101.2"), std::string::npos) << table;
  const std::string log = ReadText(site.dir / "mlp-tool-changes.csv");
  EXPECT_NE(log.find(",3,"), std::string::npos) << log;
  EXPECT_NE(log.find("on lcnc-1"), std::string::npos) << log;

  // The worn tool (a 20 um chip) against the new tool's description (wear limit 0): refused,
  // the table as it was; accepted, written.
  const auto worn = site.Mlp("request " + site.Request("tool-worn", ToolJob("tools/worn")));
  EXPECT_EQ(worn.exit_code, 6) << worn.err;
  EXPECT_NE(worn.err.find("beyond the tool's wear limit"), std::string::npos) << worn.err;
  EXPECT_EQ(ReadText(site.dir / "tool.tbl"), table);
  json accepted = ToolJob("tools/worn");
  accepted["accept_findings"] = true;
  EXPECT_EQ(site.Mlp("request " + site.Request("tool-accepted", accepted)).exit_code, 0);
  EXPECT_NE(ReadText(site.dir / "tool.tbl"), table);
  // The same tool allowed 25 um of wear by its description: the chip and the build-up
  // reported, the table written without being told.
  json lenient = json::parse(ReadText(kTools + "endmill_d10_z4_new.json"));
  lenient["wear_limit_mm"] = 0.025;
  std::ofstream(site.dir / "data" / "tools" / "lenient.json") << lenient.dump();
  json within = ToolJob("tools/worn");
  within["tool"] = "tools/lenient.json";
  const auto kept = site.Mlp("request " + site.Request("tool-within", within) + " --json");
  ASSERT_EQ(kept.exit_code, 0) << kept.err;
  const json w = json::parse(kept.out);
  EXPECT_NEAR(w.at("worst_finding_mm").get<double>(), 0.020, kDiameterTolMm);
  EXPECT_NEAR(w.at("update").at("length_after_mm").get<double>(), 75.004, kLengthTolMm);
  const std::string after_worn = ReadText(site.dir / "tool.tbl");
  // Tool 12's length is 26 mm from this tool's: a wrong number, beyond the machine's limit.
  json wrong = ToolJob("tools/new");
  wrong["tool_number"] = 12;
  const auto twelve = site.Mlp("request " + site.Request("tool-twelve", wrong));
  EXPECT_EQ(twelve.exit_code, 6);
  EXPECT_NE(twelve.err.find("beyond the machine's limit"), std::string::npos) << twelve.err;

  // Folders and files outside the data folder, a manifest naming files elsewhere, a tool not in
  // the table: the input named, nothing written.
  json outside = ToolJob("../..");
  const auto up = site.Mlp("request " + site.Request("tool-up", outside));
  EXPECT_EQ(up.exit_code, 7);
  EXPECT_NE(up.err.find("not a folder inside the data folder"), std::string::npos) << up.err;
  json manifest = json::parse(ReadText(site.dir / "data" / "tools" / "new" / "images.json"));
  manifest["images"][0]["file"] = "../../../hostd.json";
  fs::create_directories(site.dir / "data" / "tools" / "sly");
  std::ofstream(site.dir / "data" / "tools" / "sly" / "images.json") << manifest.dump();
  const auto sly = site.Mlp("request " + site.Request("tool-sly", ToolJob("tools/sly")));
  EXPECT_EQ(sly.exit_code, 7);
  EXPECT_NE(sly.err.find("not a plain file name"), std::string::npos) << sly.err;
  // Issue 48 item 8: a manifest that is a 1 GiB sparse file (+1,023 MB before, and the job
  // wrote) and an image declaring 30000 x 30000 (decoded before its size was checked: +855 MB
  // for a 875 KB PNG) are refused unread and undecoded.
  const double before_mb = hostd.PeakMemoryMb();
  fs::create_directories(site.dir / "data" / "tools" / "vast");
  std::ofstream(site.dir / "data" / "tools" / "vast" / "images.json") << manifest.dump();
  fs::resize_file(site.dir / "data" / "tools" / "vast" / "images.json", std::uintmax_t{1} << 30);
  const auto vast = site.Mlp("request " + site.Request("tool-vast", ToolJob("tools/vast")));
  EXPECT_EQ(vast.exit_code, 7);
  EXPECT_NE(vast.err.find("holds more than 1048576 bytes"), std::string::npos) << vast.err;
  fs::remove(site.dir / "data" / "tools" / "vast" / "images.json");
  fs::copy(site.dir / "data" / "tools" / "new", site.dir / "data" / "tools" / "huge",
           fs::copy_options::recursive);
  const json listed = json::parse(ReadText(site.dir / "data" / "tools" / "huge" / "images.json"));
  const fs::path first = site.dir / "data" / "tools" / "huge" /
                         listed.at("images").at(0).at("file").get<std::string>();
  // The camera's PGM, its header declaring 30000 x 30000 (a decoder allocates from it).
  std::ofstream(first, std::ios::binary) << "P5\n# 900 megapixels\n30000 30000\n255\n"
                                         << std::string(4096, '\x80');
  const auto huge = site.Mlp("request " + site.Request("tool-huge", ToolJob("tools/huge")));
  EXPECT_EQ(huge.exit_code, 7);
  EXPECT_NE(huge.err.find("declares 30000 x 30000 pixels"), std::string::npos) << huge.err;
  constexpr double kAllowedGrowthMb = 100.0;  // each attack alone was over 850 MB
  std::printf("mlp-hostd peak memory: %.1f MB before, +%.1f MB after the vast and huge folders\n",
              before_mb, hostd.PeakMemoryMb() - before_mb);
  EXPECT_LT(hostd.PeakMemoryMb() - before_mb, kAllowedGrowthMb);
  json missing = ToolJob("tools/new");
  missing["tool_number"] = 9;
  const auto nine = site.Mlp("request " + site.Request("tool-nine", missing));
  EXPECT_EQ(nine.exit_code, 7);
  EXPECT_NE(nine.err.find("tool 9 is not in"), std::string::npos) << nine.err;
  EXPECT_EQ(ReadText(site.dir / "tool.tbl"), after_worn);

  // An EDM electrode (seed 000 example 5) worn corner by corner, turned in a chuck that says
  // its angle (to 2 deg): one corner 30 um shorter against its 25 um limit refuses the write;
  // accepted, each corner's wear in the reply and the shortest corner's length in the table.
  fs::copy_file(kTools + "electrode_10x6.json",
                site.dir / "data" / "tools" / "electrode_10x6.json");
  ASSERT_EQ(RunProcess(kMlp + " tool render --tool " + kTools + "electrode_10x6_worn.json --out " +
                       (site.dir / "data" / "tools" / "electrode").string() +
                       " --rpm 5000 --fps 50 --resolution-deg 3.6 --pulse-share 0.1 --drops 0 "
                       "--seed 7 --start-deg 40")
                .exit_code,
            0);
  json edm = {{"op", "tool"},
              {"machine", "lcnc-1"},
              {"images", "tools/electrode"},
              {"tool", "tools/electrode_10x6.json"},
              {"tool_number", 30},
              {"start_turn_deg", 42.0}};
  const std::string before_edm = ReadText(site.dir / "tool.tbl");
  const auto edm_worn = site.Mlp("request " + site.Request("edm-worn", edm));
  EXPECT_EQ(edm_worn.exit_code, 6) << edm_worn.err;
  EXPECT_NE(edm_worn.err.find("beyond the tool's wear limit"), std::string::npos) << edm_worn.err;
  EXPECT_EQ(ReadText(site.dir / "tool.tbl"), before_edm);
  edm["accept_findings"] = true;
  const auto edm_set = site.Mlp("request " + site.Request("edm-set", edm) + " --json");
  ASSERT_EQ(edm_set.exit_code, 0) << edm_set.err << edm_set.out;
  const json e = json::parse(edm_set.out);
  EXPECT_FALSE(e.at("half_turn_ambiguous").get<bool>());
  EXPECT_NEAR(e.at("worst_wear_mm").get<double>(), 0.030, kLengthTolMm);
  const double in_um[] = {8, 3, 16, 1}, up_um[] = {12, 4, 20, 30};  // the worn sample's truth
  for (const json& f : e.at("flutes")) {
    const int k = f.at("edge").get<int>() - 1;
    std::printf("electrode corner %d: in %.2f um (true %.0f), up %.2f um (true %.0f)\n", k + 1,
                f.at("radial_wear_mm").get<double>() * 1e3, in_um[k],
                f.at("axial_wear_mm").get<double>() * 1e3, up_um[k]);
    EXPECT_NEAR(f.at("radial_wear_mm").get<double>(), in_um[k] * 1e-3, kLengthTolMm);
    EXPECT_NEAR(f.at("axial_wear_mm").get<double>(), up_um[k] * 1e-3, kLengthTolMm);
  }
  EXPECT_NEAR(e.at("update").at("length_after_mm").get<double>(), 59.996, kLengthTolMm);
  edm["start_turn_deg"] = 1000;
  EXPECT_EQ(site.Mlp("request " + site.Request("edm-bad", edm)).exit_code, 7);

  // Two cameras (seed 000 example 7): the D2 end mill wholly in view of both, the second's view
  // turned 74 deg (the mount says 72), the spindle drifted 6 um along the first's view: T21
  // gets the two cameras' length and diameter, the reply the axis in depth.
  const std::string d2 = " --tool " + kTools +
                         "endmill_d2_z4_runout.json --rpm 5000 --fps 50 --resolution-deg 14.4 "
                         "--pulse-share 0.1 --drops 0 --axis-u-px 511.5 --tip-v-px 700 "
                         "--drift-x-mm 0.006 --drift-y-mm -0.004 --out ";
  ASSERT_EQ(RunProcess(kMlp + " tool render --seed 3" + d2 +
                       (site.dir / "data" / "tools" / "cam_a").string())
                .exit_code,
            0);
  ASSERT_EQ(RunProcess(kMlp + " tool render --seed 4 --view-deg 74" + d2 +
                       (site.dir / "data" / "tools" / "cam_b").string())
                .exit_code,
            0);
  fs::copy_file(kTools + "endmill_d2_z4_runout.json",
                site.dir / "data" / "tools" / "endmill_d2.json");
  json pair = {{"op", "tool"},
               {"machine", "lcnc-1"},
               {"images", "tools/cam_a"},
               {"second_view", "tools/cam_b"},
               {"view_deg", 72},
               {"tool", "tools/endmill_d2.json"},
               {"tool_number", 21}};
  const auto two = site.Mlp("request " + site.Request("two-cameras", pair) + " --json");
  ASSERT_EQ(two.exit_code, 0) << two.err << two.out;
  const json tv = json::parse(two.out);
  std::printf("two cameras: axis (%+.2f, %+.2f) um, T21 length %.5f, diameter %.5f mm\n",
              tv.at("two_views").at("axis_offset_mm")[0].get<double>() * 1e3,
              tv.at("two_views").at("axis_offset_mm")[1].get<double>() * 1e3,
              tv.at("update").at("length_after_mm").get<double>(),
              tv.at("update").at("diameter_after_mm").get<double>());
  EXPECT_NEAR(tv.at("two_views").at("axis_offset_mm")[0].get<double>(), 0.006, 2 * kAxisTolMm);
  EXPECT_NEAR(tv.at("two_views").at("axis_offset_mm")[1].get<double>(), -0.004, kAxisTolMm);
  EXPECT_NEAR(tv.at("update").at("length_after_mm").get<double>(), 45.002, kLengthTolMm);
  EXPECT_NEAR(tv.at("update").at("diameter_after_mm").get<double>(), 2.006, kDiameterTolMm);
  pair["view_deg"] = 5;  // too near parallel: bad input, nothing written
  EXPECT_EQ(site.Mlp("request " + site.Request("two-parallel", pair)).exit_code, 7);

  // A touch probe (seed 000 Fig. 6/7): its idle stylus, then stopped at its trigger on the
  // glass block, 8 um after touching: T98's length becomes the gauge point's distance to the
  // face at the trigger, its diameter the ball's.
  const std::string stylus = kTools + "stylus_d2.json";
  const std::string still =
      " --rpm 600 --fps 6 --resolution-deg 90 --pulse-share 0.1 --drops 0 "
      "--axis-u-px 511.5 --tip-v-px 600 --seed 5 --out ";
  ASSERT_EQ(RunProcess(kMlp + " tool render --tool " + stylus + still +
                       (site.dir / "data" / "tools" / "idle").string())
                .exit_code,
            0);
  json deflected = json::parse(ReadText(stylus));
  deflected["edges"] = {{{"axial_offset_mm", -0.008}}};
  std::ofstream(site.dir / "deflected.json") << deflected.dump();
  ASSERT_EQ(RunProcess(kMlp + " tool render --tool " + (site.dir / "deflected.json").string() +
                       " --glass-face-h-mm 0.008" + still +
                       (site.dir / "data" / "tools" / "trigger").string())
                .exit_code,
            0);
  fs::copy_file(stylus, site.dir / "data" / "tools" / "stylus_d2.json");
  json touch = {{"op", "tool"},
                {"machine", "lcnc-1"},
                {"images", "tools/idle"},
                {"trigger", "tools/trigger"},
                {"tool", "tools/stylus_d2.json"},
                {"tool_number", 98}};
  const auto probe = site.Mlp("request " + site.Request("touch", touch) + " --json");
  ASSERT_EQ(probe.exit_code, 0) << probe.err << probe.out;
  const json p = json::parse(probe.out);
  std::printf("touch probe: pretravel %.2f um, trigger length %.5f mm, ball D %.5f mm\n",
              p.at("stylus").at("pretravel_mm").get<double>() * 1e3,
              p.at("update").at("length_after_mm").get<double>(),
              p.at("update").at("diameter_after_mm").get<double>());
  EXPECT_NEAR(p.at("stylus").at("pretravel_mm").get<double>(), 0.008, kPretravelTolMm);
  EXPECT_NEAR(p.at("update").at("length_after_mm").get<double>(), 59.992, kPretravelTolMm);
  EXPECT_NEAR(p.at("update").at("diameter_after_mm").get<double>(), 2.0, kDiameterTolMm);
  EXPECT_NE(ReadText(site.dir / "tool.tbl").find("T98 P98 Z59.992"), std::string::npos)
      << ReadText(site.dir / "tool.tbl");
  // Sideways against the block's side faces: 6 um of pretravel on +y, 4 um on -y (the ball
  // pushed back by it, the face fixed): T98's diameter becomes the effective 1.990 mm.
  for (const auto& [side, face_mm, pushed_mm] :
       {std::tuple{"plus", 0.994, -0.006}, std::tuple{"minus", -0.996, 0.004}}) {
    const std::string at = " --glass-side-y-mm " + std::to_string(face_mm) + " --drift-y-mm " +
                           std::to_string(pushed_mm);
    ASSERT_EQ(RunProcess(kMlp + " tool render --tool " + stylus + at + still +
                         (site.dir / "data" / "tools" / side).string())
                  .exit_code,
              0);
  }
  touch["trigger_sides"] = {"tools/plus", "tools/minus"};
  const auto sides = site.Mlp("request " + site.Request("touch-sides", touch) + " --json");
  ASSERT_EQ(sides.exit_code, 0) << sides.err << sides.out;
  const json s = json::parse(sides.out);
  std::printf("touch probe sideways: pretravel %.2f / %.2f um, effective D %.5f mm\n",
              s.at("stylus").at("lateral")[0].at("pretravel_mm").get<double>() * 1e3,
              s.at("stylus").at("lateral")[1].at("pretravel_mm").get<double>() * 1e3,
              s.at("update").at("diameter_after_mm").get<double>());
  EXPECT_NEAR(s.at("stylus").at("lateral")[0].at("pretravel_mm").get<double>(), 0.006,
              kPretravelTolMm);
  EXPECT_NEAR(s.at("stylus").at("lateral")[1].at("pretravel_mm").get<double>(), 0.004,
              kPretravelTolMm);
  EXPECT_NEAR(s.at("update").at("diameter_after_mm").get<double>(), 1.990, kDiameterTolMm);
  touch["trigger_sides"] = {"tools/plus", "tools/plus"};  // both on one side: bad input
  EXPECT_EQ(site.Mlp("request " + site.Request("touch-one-side", touch)).exit_code, 7);
  touch.erase("trigger_sides");
  touch.erase("trigger");  // a stylus without its trigger frames: bad input
  EXPECT_EQ(site.Mlp("request " + site.Request("touch-bad", touch)).exit_code, 7);
  EXPECT_EQ(hostd.Stop(), 0);
}

// T3's length and diameter in the table, {NaN, NaN} when the table is not whole.
std::pair<double, double> Tool3(const fs::path& table) {
  const std::string text = ReadText(table);
  std::smatch m;
  if (text.find(";D2 end mill") == std::string::npos ||
      !std::regex_search(text, m, std::regex(R"(T3 P3 Z\+?(-?[0-9.]+) D\+?(-?[0-9.]+))")))
    return {NAN, NAN};
  return {std::stod(m[1]), std::stod(m[2])};
}

// Issue 48's "a kill -9 test per job kind with a write", the tool job: kill -9 at random
// instants inside each job (the new and the worn tool's images by turns, so each request
// changes the table), the request retried under its request_id after a restart. The table is
// whole after every kill, holds the request's values after every retry, and the history has no
// write left as an intent and no request written twice.
TEST(ToolJob, KillsInsideToolJobsLeaveTheTableWholeAndWriteOnce) {
  Site site("tool_job_kill", kToolKillPort);
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["machines"][1]["controller"]["write_tool_table"] = true;
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  const fs::path table = site.dir / "tool.tbl";
  std::ofstream(table) << kTable;
  EndMillImages(site);
  if (HasFatalFailure()) return;
  const auto start = [&] {
    Child c({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
    EXPECT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }));
    return c;
  };
  constexpr int kKills = 8;
  std::mt19937 rng(4806);
  double job_ms = 1000;
  for (int i = 0; i < kKills; ++i) {
    json job = ToolJob(i % 2 == 0 ? "tools/new" : "tools/worn");
    job["accept_findings"] = true;  // the worn tool's 20 um is written, not refused
    job["request_id"] = "tool-kill-" + std::to_string(i);
    const std::string file = site.Request("kill" + std::to_string(i), job);
    bool whole_after_kill = false;
    const KillRetry r = KillThenRetry(site, file, start, &rng, &job_ms,
                                      [&] { whole_after_kill = !std::isnan(Tool3(table).first); });
    ASSERT_TRUE(whole_after_kill) << "a cut table:\n" << ReadText(table);
    ASSERT_EQ(r.retry.exit_code, 0) << i << r.retry.err << ReadText(site.dir / "hostd.log");
    EXPECT_EQ(r.stop_code, 0);
    const ProcessRun& retry = r.retry;
    const json update = json::parse(retry.out).at("update");
    const auto [z, d] = Tool3(table);
    EXPECT_NEAR(z, update.at("length_after_mm").get<double>(), 1e-6) << i;
    EXPECT_NEAR(d, update.at("diameter_after_mm").get<double>(), 1e-6) << i;
  }
  history::History h((site.dir / "data" / "history.sqlite").string());
  std::map<std::string, int> written_by_request;
  int started = 0;
  for (const auto& job : h.ListJobs({"lcnc-1", "tool", {}, 10000})) {
    ++started;
    const json j = h.ExportJob(job.id);
    bool wrote = false;
    for (const json& w : j.at("offset_writes")) {
      EXPECT_NE(w.at("state"), "intent") << job.id;
      wrote = wrote || w.at("state") == "written";
    }
    if (wrote) ++written_by_request[j.at("request").value("request_id", "")];
  }
  for (const auto& [id, n] : written_by_request) EXPECT_EQ(n, 1) << id << " written twice";
  std::printf("kill -9 inside tool jobs: %d kills, %d jobs started; a job %.0f ms\n", kKills,
              started, job_ms);
  EXPECT_GT(started, kKills);  // not vacuous: some kills cut a job short
}

}  // namespace
}  // namespace mlp::test
