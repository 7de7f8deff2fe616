// Colour frames as cameras save them (issue 18): BMP in its common variants and raw
// Bayer mosaics, each weighed to the one value per pixel the firmware works on. Known pixels in,
// exact values out; every unreadable variant a typed error.

#include "mlp/probe_fw/frame_io.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

namespace mlp::probe_fw {
namespace {

namespace fs = std::filesystem;
using Rgb = std::array<int, 3>;
using uchar = unsigned char;

constexpr int kW = 7, kH = 5;  // odd width: BMP rows are padded to 4 bytes
const ChannelWeights kRedLaser{true, 1.0, -1.0, 0.0};
const ChannelWeights kGreen{true, 0.0, 1.0, 0.0};

Rgb PixelAt(int x, int y) { return {30 * x + 10, 40 * y + 5, 250 - 20 * x}; }

// One folder per process: ctest -j runs this binary's tests side by side, and two of them
// write m.raw (seen: one read the other's pattern, GRBG channel 0 giving 100 for 3200).
fs::path Dir() {
  const fs::path d =
      fs::temp_directory_path() / ("mlp_colour_frames_test_" + std::to_string(::getpid()));
  fs::create_directories(d);
  return d;
}

// What the weights must give for PixelAt (frame_io.h: clamped, a clipped positive channel is
// full scale; none clips here).
int Expected(const ChannelWeights& w, const Rgb& p) {
  const double v = w.r * p[0] + w.g * p[1] + w.b * p[2];
  return static_cast<int>(std::clamp(std::round(v), 0.0, 255.0));
}

void ExpectPixels(const Frame& f, const ChannelWeights& w) {
  ASSERT_EQ(f.aoi.width, kW);
  ASSERT_EQ(f.aoi.height, kH);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      EXPECT_EQ(f.pixels[size_t(y * kW + x)], Expected(w, PixelAt(x, y))) << x << "," << y;
}

void Put32(std::vector<unsigned char>* b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b->push_back(static_cast<unsigned char>(v >> (8 * i)));
}
void Put16(std::vector<unsigned char>* b, std::uint16_t v) {
  b->push_back(static_cast<unsigned char>(v)), b->push_back(static_cast<unsigned char>(v >> 8));
}

// A BMP written by hand: `bits` 8 (palette of the image's colours, or grey), 24 or 32
// (with bit fields), rows top-down when `top_down`.
std::vector<unsigned char> Bmp(int bits, bool top_down, bool grey_palette, int compression) {
  std::vector<Rgb> palette;
  std::vector<int> index;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      Rgb p = PixelAt(x, y);
      if (grey_palette) p = {p[0], p[0], p[0]};
      index.push_back(int(palette.size()));
      palette.push_back(p);
    }
  const std::uint32_t stride = (kW * bits + 31) / 32 * 4;
  const std::uint32_t masks = compression == 3 ? 12 : 0;
  const std::uint32_t pal = bits == 8 ? 4 * std::uint32_t(palette.size()) : 0;
  const std::uint32_t offset = 14 + 40 + masks + pal;
  std::vector<unsigned char> b = {'B', 'M'};
  Put32(&b, offset + stride * kH), Put32(&b, 0), Put32(&b, offset);
  Put32(&b, 40), Put32(&b, kW), Put32(&b, std::uint32_t(top_down ? -kH : kH));
  Put16(&b, 1), Put16(&b, std::uint16_t(bits)), Put32(&b, std::uint32_t(compression));
  Put32(&b, stride * kH), Put32(&b, 2835), Put32(&b, 2835);
  Put32(&b, bits == 8 ? std::uint32_t(palette.size()) : 0), Put32(&b, 0);
  if (masks) Put32(&b, 0x00ff0000u), Put32(&b, 0x0000ff00u), Put32(&b, 0x000000ffu);
  if (bits == 8)
    for (const Rgb& p : palette) b.insert(b.end(), {uchar(p[2]), uchar(p[1]), uchar(p[0]), 0});
  for (int r = 0; r < kH; ++r) {
    const int y = top_down ? r : kH - 1 - r;
    std::vector<unsigned char> row;
    for (int x = 0; x < kW; ++x) {
      const Rgb p = PixelAt(x, y);
      if (bits == 8) row.push_back(uchar(index[size_t(y * kW + x)]));
      if (bits >= 24) row.insert(row.end(), {uchar(p[2]), uchar(p[1]), uchar(p[0])});
      if (bits == 32) row.push_back(255);
    }
    row.resize(stride, 0);
    b.insert(b.end(), row.begin(), row.end());
  }
  return b;
}

std::string Write(const std::string& name, const std::vector<unsigned char>& bytes) {
  const fs::path p = Dir() / name;
  std::ofstream(p, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  return p.string();
}

TEST(ColourFrames, BmpVariantsGiveTheWeighedPixels) {
  Frame f;
  for (int bits : {24, 32})
    for (bool top_down : {false, true}) {
      ReadImage(Write("c.bmp", Bmp(bits, top_down, false, bits == 32 ? 3 : 0)), &f, kRedLaser);
      ExpectPixels(f, kRedLaser);
      ReadImage(Write("c.bmp", Bmp(bits, top_down, false, 0)), &f, kGreen);
      ExpectPixels(f, kGreen);
    }
  ReadImage(Write("p.bmp", Bmp(8, false, false, 0)), &f, kRedLaser);  // a colour palette
  ExpectPixels(f, kRedLaser);
  // A grey palette is a grey image: no weights needed, the grey value itself.
  ReadImage(Write("g.bmp", Bmp(8, true, true, 0)), &f);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) EXPECT_EQ(f.pixels[size_t(y * kW + x)], PixelAt(x, y)[0]);
  // BMP and colour PNG as OpenCV writes them (24-bit bottom-up; 8-bit RGB): real camera images
  // through both in tests/calib/blaser_test.cc (not here: this test runs on the probe's arm64
  // sysroot too, which has no image codecs).
}

TEST(ColourFrames, UnreadableBmpsAreTypedErrors) {
  Frame f;
  EXPECT_THROW(ReadImage(Write("c.bmp", Bmp(24, false, false, 0)), &f), FrameIoError);  // colour
  EXPECT_THROW(ReadImage(Write("r.bmp", Bmp(8, false, false, 1)), &f, kRedLaser), FrameIoError);
  auto cut = Bmp(24, false, false, 0);
  cut.resize(cut.size() - 10);
  EXPECT_THROW(ReadImage(Write("t.bmp", cut), &f, kRedLaser), FrameIoError);  // truncated
  auto b16 = Bmp(24, false, false, 0);
  b16[28] = 16;  // 16 bits per pixel
  EXPECT_THROW(ReadImage(Write("16.bmp", b16), &f, kRedLaser), FrameIoError);
  auto core = Bmp(24, false, false, 0);
  core[14] = 12;  // an OS/2 core header
  EXPECT_THROW(ReadImage(Write("os2.bmp", core), &f, kRedLaser), FrameIoError);
  auto wide = Bmp(24, false, false, 0);
  wide[21] = 0x7f;  // width 2^31 - ...
  EXPECT_THROW(ReadImage(Write("w.bmp", wide), &f, kRedLaser), FrameIoError);
  EXPECT_THROW(ReadImage(Write("x.bmp", {'B', 'M', 0, 0}), &f, kRedLaser), FrameIoError);
}

// A uniform colour through each Bayer pattern: demosaiced, every pixel has it, so the weights
// pick exactly the channel they name (a pattern read as another would swap them).
TEST(ColourFrames, RawBayerPatternsGiveTheirChannels) {
  const Rgb colour = {3200, 800, 160};  // 12-bit
  const int w = 16, h = 12;
  const std::map<std::string, std::array<int, 4>> cell = {{"RGGB", {0, 1, 1, 2}},
                                                          {"BGGR", {2, 1, 1, 0}},
                                                          {"GRBG", {1, 0, 2, 1}},
                                                          {"GBRG", {1, 2, 0, 1}}};
  for (const auto& [pattern, sites] : cell) {
    std::vector<unsigned char> b;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        Put16(&b, std::uint16_t(colour[size_t(sites[size_t(2 * (y % 2) + x % 2)])]));
    const std::string path = Write("m.raw", b);
    const RawBayer raw{true, pattern, w, h, 12};
    Frame f;
    for (int c = 0; c < 3; ++c) {
      const ChannelWeights one{true, c == 0 ? 1.0 : 0.0, c == 1 ? 1.0 : 0.0, c == 2 ? 1.0 : 0.0};
      ReadImage(path, &f, one, raw);
      ASSERT_EQ(f.pixels.size(), size_t(w * h));
      EXPECT_EQ(f.bit_depth, 12);
      for (auto v : f.pixels) ASSERT_EQ(v, colour[size_t(c)]) << pattern << " channel " << c;
    }
  }
}

TEST(ColourFrames, UnreadableRawFramesAreTypedErrors) {
  std::vector<unsigned char> b;
  for (int i = 0; i < 16 * 12; ++i) Put16(&b, 100);
  const std::string path = Write("m.raw", b);
  Frame f;
  const RawBayer raw{true, "RGGB", 16, 12, 12};
  EXPECT_NO_THROW(ReadImage(path, &f, kRedLaser, raw));
  EXPECT_THROW(ReadImage(path, &f, kRedLaser), FrameIoError);  // no layout
  EXPECT_THROW(ReadImage(path, &f, {}, raw), FrameIoError);    // no weights
  EXPECT_THROW(ReadImage(path, &f, kRedLaser, {true, "RGGB", 16, 13, 12}), FrameIoError);  // size
  b[0] = 0xff, b[1] = 0xff;  // 65535 in a 12-bit mosaic
  EXPECT_THROW(ReadImage(Write("big.raw", b), &f, kRedLaser, raw), FrameIoError);
  // The manifest's layout is checked where it is read.
  EXPECT_THROW(
      ParseRawBayer(
          nlohmann::json{{"pattern", "RGBG"}, {"width", 4}, {"height", 4}, {"bit_depth", 8}},
          "raw"),
      FrameIoError);
  EXPECT_THROW(
      ParseRawBayer(
          nlohmann::json{{"pattern", "RGGB"}, {"width", 4}, {"height", 4}, {"bit_depth", 17}},
          "raw"),
      FrameIoError);
}

}  // namespace
}  // namespace mlp::probe_fw
