// An EDM electrode re-clamped (seed 000 example 6) through mlp-hostd's relocate job into
// LinuxCNC's tool table: the texture recorded before and after by the virtual reflected-light
// camera (`mlp tool render-texture`), the electrode found again, its X, Y, Z and C written as
// every job's changes are (announced, within the limits, the table replaced whole, logged
// before and after); tilted beyond the limit, or on a control without those words: refused,
// nothing written. Real processes: mlp tool render-texture, mlp-hostd, mlp request.

#include <filesystem>
#include <fstream>

#include "electrode_site.h"  // kElectrode

namespace mlp::test {
namespace {

constexpr int kRelocatePort = 17463;    // the probe link's port, unused: no probe here
constexpr double kShiftTolMm = 0.0005;  // relocate_test's, through the job
constexpr double kTurnTolDeg = 0.002;
const std::string kTable =
    "T3 P3 Z+75.100000 D+10.050000 ;D10 Z4 roughing\n"
    "T30 P30 X0.01 Y0 Z60.0 C0 D11.662 ;EDM electrode 10x6\n";

void RenderTexture(const Site& site, const std::string& folder, const std::string& pose) {
  const auto r = RunProcess(kMlp + " tool render-texture --tool " + kElectrode + " --out " +
                            (site.dir / "data" / folder).string() + " " + pose);
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

TEST(RelocateJob, TheElectrodesOffsetsGoThroughTheAdapterOrAreRefused) {
  Site site("relocate_job", kRelocatePort);
  json config = json::parse(ReadText(site.dir / "hostd.json"));
  config["machines"][1]["controller"]["write_tool_table"] = true;
  config["machines"][1]["controller"]["axes"] = "XYZC";  // an EDM sinker with a C axis
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  std::ofstream(site.dir / "tool.tbl") << kTable;
  fs::create_directories(site.dir / "data" / "tools");
  fs::copy_file(kElectrode, site.dir / "data" / "tools" / "electrode.json");
  RenderTexture(site, "tools/before", "--seed 1");
  RenderTexture(site, "tools/after",
                "--seed 2 --rotation-deg 0.003,-0.004,0.4 --shift-mm 0.03,-0.02,0.015");
  RenderTexture(site, "tools/tilted", "--seed 3 --rotation-deg 0.05,0,0");
  Child hostd({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }))
      << ReadText(site.dir / "hostd.log");
  json job = {{"op", "relocate"},
              {"machine", "lcnc-1"},
              {"reference", "tools/before"},
              {"images", "tools/tilted"},
              {"tool", "tools/electrode.json"},
              {"tool_number", 30}};

  // Tilted 0.05 deg: refused, the table untouched.
  const auto tilted = site.Mlp("request " + site.Request("tilted", job) + " --json");
  EXPECT_EQ(tilted.exit_code, 6) << tilted.err << tilted.out;
  EXPECT_NE(tilted.out.find("clamp it again"), std::string::npos) << tilted.out;
  EXPECT_EQ(ReadText(site.dir / "tool.tbl"), kTable);

  // Turned 0.4 deg and shifted: T30's X, Y, Z and C corrected, the rest of the table kept.
  job["images"] = "tools/after";
  const auto run = site.Mlp("request " + site.Request("after", job) + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const json u = json::parse(run.out).at("update");
  std::printf("relocate job: X %.5f, Y %.5f, Z %.5f mm, C %.4f deg\n",
              u.at("x_after_mm").get<double>(), u.at("y_after_mm").get<double>(),
              u.at("length_after_mm").get<double>(), u.at("c_after_deg").get<double>());
  EXPECT_NEAR(u.at("x_before_mm").get<double>(), 0.01, 1e-9);
  EXPECT_NEAR(u.at("x_after_mm").get<double>(), 0.01 - 0.03, kShiftTolMm);
  EXPECT_NEAR(u.at("y_after_mm").get<double>(), 0.02, kShiftTolMm);
  EXPECT_NEAR(u.at("length_after_mm").get<double>(), 60.0 - 0.015, kShiftTolMm);
  EXPECT_NEAR(u.at("c_after_deg").get<double>(), -0.4, kTurnTolDeg);
  const std::string table = ReadText(site.dir / "tool.tbl");
  EXPECT_NE(table.find("T3 P3 Z+75.100000 D+10.050000 ;D10 Z4 roughing"), std::string::npos)
      << table;
  EXPECT_NE(table.find(";EDM electrode 10x6"), std::string::npos) << table;
  EXPECT_EQ(table.find("X0.01 "), std::string::npos) << table;
  const std::string log = ReadText(site.dir / "mlp-tool-changes.csv");
  EXPECT_NE(log.find(",30,"), std::string::npos) << log;
  EXPECT_NE(log.find("; C 0.00000 -> -0.399"), std::string::npos) << log;  // -0.4 deg, measured

  // The same machine without its C axis: the 0.4 deg turn is not corrected, so refused.
  config["machines"][1]["controller"]["axes"] = "XYZ";
  std::ofstream(site.dir / "hostd.json") << config.dump(1);
  EXPECT_EQ(hostd.Stop(), 0);
  Child again({kHostd, "--config", (site.dir / "hostd.json").string()}, site.dir / "hostd2.log");
  ASSERT_TRUE(site.WaitFor([&] { return site.Mlp("status").exit_code == 0; }));
  const std::string written = ReadText(site.dir / "tool.tbl");
  const auto no_c = site.Mlp("request " + site.Request("no-c", job) + " --json");
  EXPECT_EQ(no_c.exit_code, 6) << no_c.err << no_c.out;
  EXPECT_NE(no_c.out.find("no C axis"), std::string::npos) << no_c.out;
  EXPECT_EQ(ReadText(site.dir / "tool.tbl"), written);

  // Bad input: not an electrode, a folder outside the data folder, an unknown field.
  fs::copy_file(mlp::test::SourceDir() + "/samples/tools/endmill_d10_z4_new.json",
                site.dir / "data" / "tools" / "endmill.json");
  json bad = job;
  bad["tool"] = "tools/endmill.json";
  EXPECT_EQ(site.Mlp("request " + site.Request("cutter", bad)).exit_code, 7);
  bad = job, bad["reference"] = "../..";
  EXPECT_EQ(site.Mlp("request " + site.Request("outside", bad)).exit_code, 7);
  bad = job, bad["max_tilt_deg"] = 5;
  EXPECT_EQ(site.Mlp("request " + site.Request("tilt-limit", bad)).exit_code, 7);
  EXPECT_EQ(again.Stop(), 0);
}

}  // namespace
}  // namespace mlp::test
