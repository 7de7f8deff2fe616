// The firmware program as the probe runs it, serving the real host service: `mlp-fw serve` with
// a camera that replays frames rendered to disk and the virtual mirror, on the authenticated
// link to a running `mlp-hostd`, asked by the macro's client `mlp`. The host's cloud must be
// the one `mlp-fw run` makes from the same frames, bit for bit once both are put on the link's
// 0.1 um grid; requests the recording cannot answer get typed errors the host's status shows.

#include "mlp/link/cloud_codec.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/frame_source.h"
#include "mlp/probe_fw/roi_spec.h"
#include "mlp/probe_fw/triangulate.h"

#include <cstring>

#include "hostd_site.h"
#include "test_data.h"

namespace mlp {
namespace {

using test::Child;
using test::kProbe;
using test::kScene;
using test::RunProcess;
using test::Site;
using json = nlohmann::json;
namespace fs = std::filesystem;

const std::string kFw = mlp::test::Program("mlp-fw");
constexpr int kPort = 17460;
constexpr size_t kMinPoints = 5000;  // the top face fills the 200 x 200 px window

std::string Text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);  // round-trips the double
  return buf;
}

// The firmware's cloud from the frames on disk, as `mlp-fw run --roi full` computes it.
link::LinkCloud ReconstructFromDisk(const std::string& dir) {
  const probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kProbe);
  const auto source = probe_fw::OpenDirectorySource(dir);
  std::vector<probe_fw::Frame> laser;
  probe_fw::Frame f, led;
  while (source->Next(&f)) {
    if (f.IsLaser())
      laser.push_back(f);
    else
      led = f;
  }
  const probe_fw::RowMask mask = probe_fw::ParseRoi("full", laser.at(0).aoi, &led);
  link::LinkCloud cloud;
  probe_fw::StripeCounts counts;
  for (const auto& p : probe_fw::ReconstructSweep(model, laser, mask, {}, &counts)) {
    for (int a = 0; a < 3; ++a) cloud.xyz.push_back(p.point_in_probe(a));
    cloud.quality.push_back(static_cast<float>(p.quality));
  }
  return cloud;
}

// Every stored float of the file equals the float of `expected`, bit for bit.
void ExpectSameFloats(const std::string& path, const link::LinkCloud& expected) {
  const probe_fw::CloudFile file = probe_fw::ReadCloudPly(path);
  ASSERT_EQ(file.quality.size(), expected.size()) << path;
  size_t differ = 0;
  for (size_t i = 0; i < file.xyz.size(); ++i) {
    const float a = static_cast<float>(file.xyz[i]), b = static_cast<float>(expected.xyz[i]);
    differ += std::memcmp(&a, &b, sizeof a) != 0;
  }
  for (size_t i = 0; i < file.quality.size(); ++i)
    differ += std::memcmp(&file.quality[i], &expected.quality[i], sizeof(float)) != 0;
  EXPECT_EQ(differ, 0u) << path << ": numbers that differ";
}

TEST(FirmwareServe, AnswersTheHostFromRecordedFramesWithTheCloudMlpFwRunMakes) {
  Site site("fw_serve", kPort);
  const sim::VirtualProbe vp(probe_fw::LoadProbeModel(kProbe), sim::LoadScene(kScene));
  const sim::Capture& top = vp.scene().captures.at(0);
  ASSERT_EQ(top.id, "top_face");
  const probe_fw::Aoi aoi{924, 668, 200, 200};
  json request = host::SceneCaptureRequest("vmc-1", vp, top, aoi);
  const json& columns = request.at("columns");
  const std::string frames = (site.dir / "frames").string();
  const auto render =
      RunProcess(test::kSim + " render --probe " + kProbe + " --scene " + kScene +
                 " --capture top_face --aoi 924,668,200,200 --columns " + Text(columns[0]) + ":" +
                 Text(columns[1]) + ":" + Text(columns[2]) + " --seed 7 --out " + frames);
  ASSERT_EQ(render.exit_code, 0) << render.err;

  Child hostd({test::kHostd, "--config", (site.dir / "hostd.json").string()},
              site.dir / "hostd.log");
  ASSERT_TRUE(site.WaitFor([&] { return fs::exists(site.socket); }));
  Child probe({kFw, "serve", "--probe", kProbe, "--port", std::to_string(kPort), "--key",
               (site.dir / "probe.key").string(), "--frames-from", frames},
              site.dir / "fw.log");
  ASSERT_TRUE(test::ProbeConnected(site)) << test::ReadText(site.dir / "fw.log");

  const auto served = site.Mlp("request " + site.Request("top", request));
  ASSERT_EQ(served.exit_code, 0) << served.out << served.err;
  const json reply = json::parse(served.out);
  const auto ran = RunProcess(kFw + " run --probe " + kProbe + " --frames " + frames +
                              " --roi full --out " + (site.dir / "run.ply").string());
  ASSERT_EQ(ran.exit_code, 0) << ran.err;

  const link::LinkCloud firmware = ReconstructFromDisk(frames);
  ASSERT_GT(firmware.size(), kMinPoints);
  EXPECT_EQ(reply.at("points"), firmware.size());
  ExpectSameFloats((site.dir / "run.ply").string(), firmware);
  ExpectSameFloats(reply.at("cloud_path"), link::Quantised(firmware));

  // Another window than the recording's: the request's fault, said so; the probe serves on.
  json window = request;
  window["aoi"] = {900, 668, 200, 200};
  const auto refused = site.Mlp("request " + site.Request("window", window));
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE((refused.out + refused.err).find("bad_request"), std::string::npos)
      << refused.out << refused.err;
  EXPECT_NE((refused.out + refused.err).find("window"), std::string::npos) << refused.out;
  // Columns never recorded: the camera has no frame for them, a capture failure.
  json shifted = request;
  shifted["columns"] = {columns[0].get<double>() + 1.0, columns[1].get<double>() + 1.0, 2.0};
  const auto failed = site.Mlp("request " + site.Request("shifted", shifted));
  EXPECT_NE(failed.exit_code, 0);
  EXPECT_NE((failed.out + failed.err).find("capture_failed"), std::string::npos)
      << failed.out << failed.err;
  EXPECT_NE((failed.out + failed.err).find("no frame was recorded at column"), std::string::npos)
      << failed.out;
  EXPECT_TRUE(site.WaitFor([&] {
    const auto s = site.Mlp("status --json");
    if (s.exit_code != 0) return false;
    const json p = json::parse(s.out).at("probes").at(0);
    return p.value("last_error", "") == "capture_failed" && p.value("frames_dropped", -1) == 0;
  })) << site.Mlp("status --json").out;
  const auto again = site.Mlp("request " + site.Request("again", request));
  EXPECT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_EQ(probe.Stop(), 0) << "SIGTERM stops the probe cleanly";
}

}  // namespace
}  // namespace mlp
