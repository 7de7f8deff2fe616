// mlp-sim and mlp-fw as real processes on real files: render a capture, reconstruct it, fit the
// cloud with `mlp fit`; and the exit codes and messages of bad input.

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "test_data.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

namespace {

namespace fs = std::filesystem;

struct ProcessRun {
  int exit_code;
  std::string out;  // stdout, then stderr (2>&1)
};

ProcessRun Exec(const std::string& cmd) {
  FILE* pipe = popen((cmd + " 2>&1").c_str(), "r");
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof(buf), pipe)) out.append(buf, n);
  const int status = pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

const std::string kProbe = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
const std::string kScene = mlp::test::SourceDir() + "/samples/scenes/bore_block.json";
const std::string kSim = mlp::test::Program("mlp-sim"), kFw = mlp::test::Program("mlp-fw"),
                  kMlp = mlp::test::Program("mlp");

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("mlp_probe_cli_" + name);
  fs::remove_all(dir);
  return dir;
}

// Renders the sample scene's top-face capture into `dir`; returns mlp-sim's exit code.
int RenderTopFace(const fs::path& dir, const std::string& options) {
  return Exec(kSim + " render --probe " + kProbe + " --scene " + kScene + " --out " + dir.string() +
              " --capture top_face " + options)
      .exit_code;
}

// The sample scene's top-face capture looks straight down from 120 mm at the face z = 0.
TEST(ProbeCli, RenderReconstructAndFitTheTopFace) {
  const fs::path dir = TempDir("top");
  const ProcessRun sim =
      Exec(kSim + " render --probe " + kProbe + " --scene " + kScene + " --out " + dir.string() +
           " --capture top_face --aoi 924,668,200,200 --seed 3");
  ASSERT_EQ(sim.exit_code, 0) << sim.out;
  EXPECT_TRUE(fs::exists(dir / "frames.json"));
  EXPECT_TRUE(fs::exists(dir / "truth.json"));
  const std::string cloud = (dir / "cloud.ply").string();
  const ProcessRun fw = Exec(kFw + " run --probe " + kProbe + " --frames " + dir.string() +
                             " --roi full --out " + cloud + " --json");
  ASSERT_EQ(fw.exit_code, 0) << fw.out;
  const auto summary = nlohmann::json::parse(fw.out.substr(fw.out.find('{')));
  EXPECT_GT(summary.at("points").get<int>(), 9000);
  const ProcessRun fit = Exec(kMlp + " fit plane " + cloud);
  ASSERT_EQ(fit.exit_code, 0) << fit.out;
  const auto plane = nlohmann::json::parse(fit.out);
  // In the probe frame the face is z = 120 mm (the flange is 120 mm above it).
  constexpr double kPlaneTolMm = 0.001;  // the board plane through the command
  EXPECT_NEAR(plane.at("point")[2].get<double>(), 120.0, kPlaneTolMm);
  constexpr double kNormalTol = 1e-6;  // its normal against +Z (unit vector)
  EXPECT_NEAR(plane.at("normal")[2].get<double>(), 1.0, kNormalTol);
  EXPECT_LT(plane.at("rms").get<double>(), 0.005);
  fs::remove_all(dir);
}

TEST(ProbeCli, ARoiRectangleLimitsTheCloud) {
  const fs::path dir = TempDir("rect");
  ASSERT_EQ(RenderTopFace(dir, "--aoi 924,668,200,200 --format pgm"), 0);
  const ProcessRun fw =
      Exec(kFw + " run --probe " + kProbe + " --frames " + dir.string() +
           " --roi rect:924,668,200,50 --out " + (dir / "c.ply").string() + " --json");
  ASSERT_EQ(fw.exit_code, 0) << fw.out;
  const auto summary = nlohmann::json::parse(fw.out.substr(fw.out.find('{')));
  EXPECT_EQ(summary.at("roi_pixels").get<int>(), 200 * 50);
  EXPECT_GT(summary.at("points").get<int>(), 2000);
  EXPECT_LE(summary.at("points").get<int>(), 50 * 60);  // one point per ROI row and frame
  fs::remove_all(dir);
}

TEST(ProbeCli, BadInputGivesExitTwoAndWritesNothing) {
  const fs::path dir = TempDir("bad");
  ASSERT_EQ(RenderTopFace(dir, "--aoi 1000,700,64,64"), 0);
  const std::string out = " --out " + (dir / "c.ply").string();
  // A probe model of another serial: frames must not be triangulated with the wrong calibration.
  std::string other =
      std::string(std::istreambuf_iterator<char>(std::ifstream(kProbe).rdbuf()), {});
  other.replace(other.find("MLP-REF-0001"), 12, "MLP-REF-0002");
  std::ofstream(dir / "other.json") << other;
  ProcessRun r = Exec(kFw + " run --probe " + (dir / "other.json").string() + " --frames " +
                      dir.string() + " --roi full" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("MLP-REF-0001"), std::string::npos) << r.out;
  r = Exec(kFw + " run --probe " + kProbe + " --frames " + dir.string() + " --roi circle:3" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("ROI_SPEC"), std::string::npos) << r.out;
  r = Exec(kFw + " run --probe " + kProbe + " --frames /nonexistent --roi full" + out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("frames.json"), std::string::npos) << r.out;
  r = Exec(kFw + " run --probe " + kProbe + " --frames " + dir.string() + " --roi rect:0,0,10,10" +
           out);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_FALSE(fs::exists(dir / "c.ply"));
  r = Exec(kSim + " render --probe " + kProbe + " --scene " + kScene + " --out " +
           (dir / "x").string() + " --capture nowhere");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("nowhere"), std::string::npos);
  r = Exec(kSim + " render --probe " + kProbe + " --scene " + kProbe + " --out " +
           (dir / "x").string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.out.find("format"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

TEST(ProbeCli, MissingCameraIsExitThreeWithAClearReason) {
  const ProcessRun r =
      Exec(kFw + " run --probe " + kProbe +
           " --camera /dev/video-mlp-none --aoi 0,0,640,480 --columns 400:500:2 --roi full"
           " --out /tmp/mlp_never.ply");
  EXPECT_EQ(r.exit_code, 3) << r.out;
  EXPECT_NE(r.out.find("/dev/video-mlp-none"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("No such file or directory"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists("/tmp/mlp_never.ply"));
}

// The board's unit file (samples/probe_board) as systemd reads it, and its command line run
// here with its environment file: it parses, refuses a key others may read (exit 2, which the
// unit does not retry) and, with no camera or mirror driver on this machine, names the missing
// device (exit 3, retried).
TEST(ProbeCli, TheBoardsSystemdUnitIsValidAndItsCommandLineRuns) {
  const fs::path samples = fs::path(mlp::test::SourceDir()) / "samples" / "probe_board";
  const fs::path dir = TempDir("unit");
  fs::create_directories(dir);
  std::ifstream unit_in(samples / "mlp-fw.service");
  std::string unit((std::istreambuf_iterator<char>(unit_in)), std::istreambuf_iterator<char>());
  for (const char* line : {"Restart=on-failure", "RestartPreventExitStatus=2",
                           "EnvironmentFile=/etc/mlprobe/probe.env"}) {
    EXPECT_NE(unit.find(std::string("\n") + line + "\n"), std::string::npos) << line;
  }
  // Installed paths -> this build and a scratch /etc.
  const auto replace_all = [](std::string s, const std::string& from, const std::string& to) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
    return s;
  };
  unit = replace_all(replace_all(unit, "/usr/local/bin/mlp-fw", kFw), "/etc/mlprobe/",
                     dir.string() + "/");
  std::ofstream(dir / "mlp-fw.service") << unit;
  fs::copy_file(samples / "probe.env", dir / "probe.env");
  fs::copy_file(kProbe, dir / "probe.json");
  const ProcessRun verify = Exec("systemd-analyze verify " + (dir / "mlp-fw.service").string());
  EXPECT_EQ(verify.exit_code, 0) << verify.out;

  // ExecStart with the environment file's values, as systemd expands ${NAME}.
  const size_t exec_at = unit.find("\nExecStart=") + 11;
  std::string command = unit.substr(exec_at, unit.find('\n', exec_at) - exec_at);
  std::ifstream env(dir / "probe.env");
  for (std::string line; std::getline(env, line);) {
    const size_t eq = line.find('=');
    if (line.empty() || line[0] == '#' || eq == std::string::npos) continue;
    command = replace_all(command, "${" + line.substr(0, eq) + "}", line.substr(eq + 1));
  }
  ASSERT_EQ(command.find("${"), std::string::npos) << command;
  std::ofstream(dir / "probe.key") << std::string(64, 'c') << "\n";
  fs::permissions(dir / "probe.key",
                  fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read);
  ProcessRun r = Exec(command);
  EXPECT_EQ(r.exit_code, 2) << command << "\n" << r.out;
  EXPECT_NE(r.out.find("chmod 600"), std::string::npos) << r.out;
  fs::permissions(dir / "probe.key", fs::perms::owner_read | fs::perms::owner_write);
  r = Exec(command);
  EXPECT_EQ(r.exit_code, 3) << command << "\n" << r.out;
  EXPECT_TRUE(r.out.find("/dev/video0") != std::string::npos ||
              r.out.find("/dev/spidev0.0") != std::string::npos)
      << r.out;
  fs::remove_all(dir);
}

// `mlp-fw serve` refuses what it cannot run with before it connects: a key file others may read,
// the board's mirror driver missing (exit 3, named), a recording of another probe.
TEST(ProbeCli, ServeRefusesABadKeyAMissingBoardAndAForeignRecording) {
  const fs::path dir = TempDir("serve");
  ASSERT_EQ(RenderTopFace(dir / "frames", "--aoi 924,668,64,64"), 0);
  const fs::path key = dir / "probe.key";
  std::ofstream(key) << std::string(64, 'b') << "\n";
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_read);
  const std::string serve = kFw + " serve --probe " + kProbe + " --port 17461 --key " +
                            key.string() + " --frames-from " + (dir / "frames").string();
  ProcessRun r = Exec(serve);
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("chmod 600"), std::string::npos) << r.out;
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);

  r = Exec(serve + " --projector board --spi /dev/mlp-no-spi");
  EXPECT_EQ(r.exit_code, 3) << r.out;
  EXPECT_NE(r.out.find("/dev/mlp-no-spi"), std::string::npos) << r.out;
  r = Exec(serve + " --projector board --spi /dev/null");
  EXPECT_EQ(r.exit_code, 3) << r.out;
  EXPECT_NE(r.out.find("not an SPI device"), std::string::npos) << r.out;

  r = Exec(serve + " --camera /dev/video0");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("either --camera or --frames-from"), std::string::npos) << r.out;

  const fs::path other = dir / "other_probe.json";
  std::ifstream in(kProbe);
  nlohmann::json model = nlohmann::json::parse(in);
  model["serial"] = "MLP-OTHER-0002";
  std::ofstream(other) << model.dump();
  r = Exec(kFw + " serve --probe " + other.string() + " --port 17461 --key " + key.string() +
           " --frames-from " + (dir / "frames").string());
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("from probe MLP-REF-0001"), std::string::npos) << r.out;
  fs::remove_all(dir);
}

// Issue 16: the virtual probe renders the probe as built, but its firmware never reads that
// file: `mlp-sim serve` refuses to start without the model the firmware is to use.
TEST(ProbeCli, AnAsBuiltProbeRendersButItsFirmwareNeverReadsIt) {
  const fs::path dir = TempDir("as_built");
  const std::string as_built = mlp::test::SourceDir() + "/samples/probes/as_built/MLP-AB-0001.json";
  ProcessRun r = Exec(kSim + " render --probe " + as_built + " --scene " + kScene + " --out " +
                      (dir / "frames").string() + " --capture top_face --aoi 924,668,64,64");
  ASSERT_EQ(r.exit_code, 0) << r.out;
  EXPECT_TRUE(fs::exists(dir / "frames" / "frames.json"));
  const fs::path key = dir / "probe.key";
  std::ofstream(key) << std::string(64, 'b') << "\n";
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  r = Exec(kSim + " serve --probe " + as_built + " --scene " + kScene + " --port 17462 --key " +
           key.string());
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("--firmware-model"), std::string::npos) << r.out;
  // A broken as-built file is a clear error naming the field.
  std::ifstream in(as_built);
  nlohmann::json bad = nlohmann::json::parse(in);
  bad["window"]["refractive_index"] = 0.5;
  std::ofstream(dir / "bad.json") << bad.dump();
  r = Exec(kSim + " render --probe " + (dir / "bad.json").string() + " --scene " + kScene +
           " --out " + (dir / "bad").string() + " --capture top_face --aoi 924,668,64,64");
  EXPECT_EQ(r.exit_code, 2) << r.out;
  EXPECT_NE(r.out.find("refractive_index"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "bad" / "frames.json"));
  fs::remove_all(dir);
}

}  // namespace

namespace {

// The sample scene's 12 mm hole seen from straight above: the hole ROI found on the LED frame
// limits the cloud to the rim's neighbourhood.
TEST(ProbeCli, HoleRoiFromTheLedFrame) {
  const fs::path dir = TempDir("hole");
  ASSERT_EQ(Exec(kSim + " render --probe " + kProbe + " --scene " + kScene + " --out " +
                 dir.string() + " --capture small_hole_top --aoi 724,468,600,600")
                .exit_code,
            0);
  const ProcessRun fw =
      Exec(kFw + " run --probe " + kProbe + " --frames " + dir.string() +
           " --roi hole:1023.5,767.5 --out " + (dir / "c.ply").string() + " --json");
  ASSERT_EQ(fw.exit_code, 0) << fw.out;
  const auto summary = nlohmann::json::parse(fw.out.substr(fw.out.find('{')));
  // Rim radius ~232 px: annulus from 139 to 252 px.
  const double annulus = M_PI * (252.0 * 252.0 - 139.0 * 139.0);
  EXPECT_NEAR(summary.at("roi_pixels").get<double>(), annulus, 0.03 * annulus);
  EXPECT_GT(summary.at("points").get<int>(), 1000);
  fs::remove_all(dir);
}

}  // namespace
