// Frames on disk and frame sources: bit-exact round trips, lazy directory replay, the virtual
// source's order, and typed errors for broken files.

#include "mlp/probe_fw/frame_io.h"

#include "mlp/probe_fw/frame_source.h"
#include "mlp/sim/virtual_source.h"

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

namespace mlp::probe_fw {
namespace {

namespace fs = std::filesystem;

Frame RandomFrame(int bit_depth, double column, unsigned seed) {
  Frame f;
  f.aoi = {100, 50, 37, 23};  // odd sizes catch row-stride mistakes
  f.bit_depth = bit_depth;
  f.laser_column = column;
  std::mt19937 gen(seed);
  std::uniform_int_distribution<int> level(0, (1 << bit_depth) - 1);
  f.pixels.resize(37 * 23);
  for (auto& p : f.pixels) p = static_cast<std::uint16_t>(level(gen));
  return f;
}

TEST(FrameIo, CaptureDirectoryRoundTripIsBitExact) {
  for (const std::string ext : {".png", ".pgm"}) {
    for (int bits : {8, 12, 16}) {
      SCOPED_TRACE(ext + " " + std::to_string(bits));
      const fs::path dir = fs::temp_directory_path() / "mlp_frame_io_test";
      fs::remove_all(dir);
      const std::vector<Frame> frames{RandomFrame(bits, -1.0, 1), RandomFrame(bits, 470.5, 2),
                                      RandomFrame(bits, 472.5, 3)};
      WriteCaptureDir(dir.string(), {"SER-1", "cal-7", "cap-3"}, frames, ext);
      auto source = OpenDirectorySource(dir.string());
      EXPECT_EQ(source->Meta().probe_serial, "SER-1");
      EXPECT_EQ(source->Meta().capture_id, "cap-3");
      Frame f;
      for (const Frame& expected : frames) {
        ASSERT_TRUE(source->Next(&f));
        EXPECT_EQ(f.pixels, expected.pixels);
        EXPECT_EQ(f.laser_column, expected.laser_column);
        EXPECT_EQ(f.aoi.x0, 100);
        EXPECT_EQ(f.bit_depth, bits);
      }
      EXPECT_FALSE(source->Next(&f));
      fs::remove_all(dir);
    }
  }
}

TEST(FrameIo, BrokenFilesAreTypedErrors) {
  const fs::path dir = fs::temp_directory_path() / "mlp_frame_io_broken";
  fs::remove_all(dir);
  WriteCaptureDir(dir.string(), {"S", "C", "X"}, {RandomFrame(8, 3.0, 1)}, ".pgm");
  // Truncate the image: the source must say so, not return garbage.
  fs::resize_file(dir / "laser_0000.pgm", 30);
  auto source = OpenDirectorySource(dir.string());
  Frame f;
  EXPECT_THROW(source->Next(&f), FrameIoError);
  // A manifest that points outside its directory is refused.
  std::ofstream(dir / "frames.json")
      << R"({"format": "mlprobe-frames/1", "probe_serial": "S", "calibration_id": "C",
            "capture_id": "X", "frames": [{"file": "../etc/passwd", "laser_column": 1,
            "aoi": [0, 0, 1, 1], "bit_depth": 8}]})";
  EXPECT_THROW(OpenDirectorySource(dir.string()), FrameIoError);
  std::ofstream(dir / "frames.json") << R"({"format": "mlprobe-frames/2"})";
  EXPECT_THROW(OpenDirectorySource(dir.string()), FrameIoError);
  fs::remove_all(dir);
}

TEST(FrameIo, VirtualSourceGivesLedThenLaserFrames) {
  sim::RenderedCapture capture;
  capture.led = RandomFrame(8, -1.0, 1);
  capture.laser = {RandomFrame(8, 10.0, 2), RandomFrame(8, 12.0, 3)};
  auto source = sim::MakeVirtualSource(capture, {"S", "C", "X"});
  Frame f;
  ASSERT_TRUE(source->Next(&f));
  EXPECT_FALSE(f.IsLaser());
  ASSERT_TRUE(source->Next(&f));
  EXPECT_EQ(f.laser_column, 10.0);
  ASSERT_TRUE(source->Next(&f));
  EXPECT_EQ(f.pixels, capture.laser[1].pixels);
  EXPECT_FALSE(source->Next(&f));
}

}  // namespace
}  // namespace mlp::probe_fw
