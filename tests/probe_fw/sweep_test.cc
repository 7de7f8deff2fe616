// The firmware's light and camera control: the mirror driver's command words, the order of a
// sweep (LED frame first, then one laser frame per column with the mirror there), the laser
// and LEDs off on every way out, recorded frames answering what the projector lights, and the
// board's devices missing on this machine giving typed errors that name them.

#include "mlp/probe_fw/sweep.h"

#include "mlp/probe_fw/frame_io.h"
#include "mlp/probe_fw/projector.h"

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

using Bytes = std::vector<std::uint8_t>;

TEST(MirrorCommand, IsTheSetColumnWordInSixteenthsOfAColumnBigEndian) {
  EXPECT_EQ(MirrorCommand(0.0, 1023.0), (Bytes{0xA5, 0x00, 0x00, 0x00}));
  EXPECT_EQ(MirrorCommand(1.0, 1023.0), (Bytes{0xA5, 0x00, 0x00, 0x10}));
  // 512.5 columns = 8200 sixteenths = 0x002008.
  EXPECT_EQ(MirrorCommand(512.5, 1023.0), (Bytes{0xA5, 0x00, 0x20, 0x08}));
  // 1/32 column rounds to the nearest step the driver's DAC resolves: half away from zero.
  EXPECT_EQ(MirrorCommand(1.0 / 32.0, 1023.0), (Bytes{0xA5, 0x00, 0x00, 0x01}));
  EXPECT_EQ(MirrorCommand(1023.0, 1023.0), (Bytes{0xA5, 0x00, 0x3F, 0xF0}));
  EXPECT_EQ(MirrorCommand(100000.0, 1e6), (Bytes{0xA5, 0x18, 0x6A, 0x00}));
}

TEST(MirrorCommand, RefusesColumnsTheMirrorDoesNotReach) {
  EXPECT_THROW(MirrorCommand(-0.001, 1023.0), ProjectorError);
  EXPECT_THROW(MirrorCommand(1023.001, 1023.0), ProjectorError);
  EXPECT_THROW(MirrorCommand(std::nan(""), 1023.0), ProjectorError);
  EXPECT_THROW(MirrorCommand(std::numeric_limits<double>::infinity(), 1e300), ProjectorError);
  // Beyond the driver's 24 bits even where the model claims the mirror gets there.
  EXPECT_THROW(MirrorCommand(1048576.0, 2e6), ProjectorError);
  VirtualProjector projector(1023.0);
  EXPECT_THROW(projector.SetColumn(2000.0), ProjectorError);
  EXPECT_EQ(projector.Moves(), 0u);
}

// A camera that notes what the projector lit at each grab and can fail at a given grab.
class WatchingCamera : public FrameGrabber {
 public:
  WatchingCamera(const Projector& projector, int fail_at) : p_(projector), fail_at_(fail_at) {}
  void Grab(Frame* frame) override {
    seen.push_back(p_.State());
    if (static_cast<int>(seen.size()) == fail_at_) throw FrameIoError("camera: test failure");
    frame->aoi = {10, 20, 4, 3};
    frame->pixels.assign(12, static_cast<std::uint16_t>(seen.size()));
  }
  std::vector<ProjectorState> seen;

 private:
  const Projector& p_;
  int fail_at_;
};

SweepPlan ThreeColumns() {
  SweepPlan plan;
  plan.aoi = {10, 20, 4, 3};
  plan.columns = {100.0, 102.5, 105.0};
  return plan;
}

TEST(TakeSweep, TakesTheLedFrameThenOneLaserFramePerColumnAndLeavesTheLightsOff) {
  VirtualProjector projector(1023.0);
  WatchingCamera camera(projector, -1);
  const std::vector<Frame> frames = TakeSweep(projector, camera, ThreeColumns());
  ASSERT_EQ(frames.size(), 4u);
  ASSERT_EQ(camera.seen.size(), 4u);
  EXPECT_TRUE(camera.seen[0].led_on);
  EXPECT_FALSE(camera.seen[0].laser_on);
  EXPECT_FALSE(frames[0].IsLaser());
  const std::vector<double> columns = ThreeColumns().columns;
  for (size_t i = 0; i < columns.size(); ++i) {
    EXPECT_TRUE(camera.seen[i + 1].laser_on) << i;
    EXPECT_FALSE(camera.seen[i + 1].led_on) << i;
    EXPECT_EQ(camera.seen[i + 1].column, columns[i]) << i;
    EXPECT_EQ(frames[i + 1].laser_column, columns[i]) << i;
    EXPECT_EQ(frames[i + 1].pixels[0], i + 2) << "frames in grab order";
  }
  EXPECT_EQ(projector.Moves(), 3u);
  EXPECT_FALSE(projector.State().laser_on);
  EXPECT_FALSE(projector.State().led_on);
}

TEST(TakeSweep, ACameraThatFailsMidSweepLeavesTheLaserAndLedsOff) {
  for (int fail_at : {1, 3}) {  // in the LED frame, in a laser frame
    VirtualProjector projector(1023.0);
    WatchingCamera camera(projector, fail_at);
    EXPECT_THROW(TakeSweep(projector, camera, ThreeColumns()), FrameIoError) << fail_at;
    EXPECT_FALSE(projector.State().laser_on) << fail_at;
    EXPECT_FALSE(projector.State().led_on) << fail_at;
  }
  // A column beyond the mirror: the projector refuses it, the laser goes off too.
  VirtualProjector projector(101.0);
  WatchingCamera camera(projector, -1);
  EXPECT_THROW(TakeSweep(projector, camera, ThreeColumns()), ProjectorError);
  EXPECT_FALSE(projector.State().laser_on);
  EXPECT_EQ(camera.seen.size(), 2u) << "the LED frame and column 100 only";
}

Frame Lit(double column, std::uint16_t value) {
  Frame f;
  f.aoi = {0, 0, 2, 1};
  f.laser_column = column;
  f.pixels = {value, value};
  return f;
}

TEST(RecordedCamera, AnswersWithTheFrameRecordedUnderWhatTheProjectorLights) {
  VirtualProjector projector(1023.0);
  const auto camera =
      MakeRecordedCamera({Lit(-1.0, 7), Lit(100.0, 1), Lit(102.5, 2), Lit(105.0, 3)}, projector);
  Frame f;
  EXPECT_THROW(camera->Grab(&f), FrameIoError) << "lights off: nothing was recorded so";
  projector.SetLed(true);
  camera->Grab(&f);
  EXPECT_EQ(f.pixels[0], 7);
  projector.SetLed(false);
  projector.SetLaser(true);
  projector.SetColumn(102.5);
  camera->Grab(&f);
  EXPECT_EQ(f.pixels[0], 2);
  projector.SetColumn(102.5 + 1e-7);  // the same column to float noise
  camera->Grab(&f);
  EXPECT_EQ(f.pixels[0], 2);
  projector.SetColumn(103.0);
  try {
    camera->Grab(&f);
    ADD_FAILURE() << "no frame was recorded at column 103";
  } catch (const FrameIoError& e) {
    EXPECT_NE(std::string(e.what()).find("column 103"), std::string::npos) << e.what();
  }
  // A whole sweep through it gives back the recording.
  const std::vector<Frame> frames = TakeSweep(projector, *camera, ThreeColumns());
  ASSERT_EQ(frames.size(), 4u);
  EXPECT_EQ(frames[0].pixels[0], 7);
  EXPECT_EQ(frames[3].pixels[0], 3);
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(BoardDevices, AMissingOrWrongDeviceIsATypedErrorNamingIt) {
  LinuxProjectorConfig config;
  config.spi_device = "/dev/mlp-no-such-spidev";
  EXPECT_THROW(OpenLinuxProjector(config), ProjectorError);
  EXPECT_NE(ErrorOf([&] { OpenLinuxProjector(config); }).find("/dev/mlp-no-such-spidev"),
            std::string::npos);
  config.spi_device = "/dev/null";  // opens, but is no SPI device
  EXPECT_NE(ErrorOf([&] { OpenLinuxProjector(config); }).find("not an SPI device"),
            std::string::npos);

  SweepPlan plan = ThreeColumns();
  EXPECT_THROW(OpenV4l2Camera("/dev/mlp-no-such-video", plan, 8), FrameIoError);
  EXPECT_NE(ErrorOf([&] {
              OpenV4l2Camera("/dev/mlp-no-such-video", plan, 8);
            }).find("/dev/mlp-no-such-video"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { OpenV4l2Camera("/dev/null", plan, 8); }).find("not a V4L2 device"),
            std::string::npos);
}

}  // namespace
}  // namespace mlp::probe_fw
