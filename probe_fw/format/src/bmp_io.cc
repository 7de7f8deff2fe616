// Bitmaps by hand: the layout is a fixed little-endian header and raw rows (Microsoft's
// BITMAPINFOHEADER, and its V4/V5 extensions, which only add fields after it). OpenCV's
// imgcodecs reads them in one call but brings a hundred libraries onto the probe's board (see
// png_io.cc); no smaller Debian library reads BMP. Compressed bitmaps (RLE, JPEG/PNG inside) are
// refused: cameras do not write them.
//
// Raw Bayer mosaics are demosaiced by OpenCV's imgproc (bilinear), which the firmware links
// already for the stripe extractor.
#include "bmp_io.h"

#include "mlp/base/files.h"
#include "mlp/base/raster.h"

#include <array>
#include <cstdint>
#include <fstream>
#include <iterator>

#include "weigh.h"
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace mlp::probe_fw {
namespace {

constexpr std::int64_t kMaxSidePx = 16384;
constexpr std::uint32_t kRgb = 0, kBitFields = 3;  // biCompression values
constexpr size_t kFileHeaderBytes = 14, kMasksAt = 54;

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw FrameIoError("frames: " + path + ": " + what);
}

std::vector<unsigned char> ReadAll(const std::string& path) {
  const std::string bytes = base::ReadFileAs<FrameIoError>(path, "frames: ");
  return {bytes.begin(), bytes.end()};
}

std::uint32_t U32(const std::vector<unsigned char>& b, size_t at) {
  return std::uint32_t(b[at]) | std::uint32_t(b[at + 1]) << 8 | std::uint32_t(b[at + 2]) << 16 |
         std::uint32_t(b[at + 3]) << 24;
}
std::uint16_t U16(const std::vector<unsigned char>& b, size_t at) {
  return static_cast<std::uint16_t>(b[at] | b[at + 1] << 8);
}

struct BmpLayout {
  std::int64_t width = 0, height = 0;  ///< height > 0
  bool top_down = false;
  int bits = 0;
  size_t data_at = 0, stride = 0, palette_at = 0, palette_size = 0;
};

BmpLayout Layout(const std::vector<unsigned char>& b, const std::string& path) {
  if (b.size() < kMasksAt || b[0] != 'B' || b[1] != 'M') Fail(path, "not a BMP file");
  const std::uint32_t header = U32(b, 14);
  if (header != 40 && header != 108 && header != 124)
    Fail(path, "BMP header of " + std::to_string(header) + " bytes (40, 108 or 124 are read)");
  BmpLayout l;
  l.width = static_cast<std::int32_t>(U32(b, 18));
  const std::int64_t h = static_cast<std::int32_t>(U32(b, 22));
  l.top_down = h < 0, l.height = h < 0 ? -h : h;
  l.bits = U16(b, 28);
  const std::uint32_t compression = U32(b, 30);
  if (l.width <= 0 || l.height == 0 || l.width > kMaxSidePx || l.height > kMaxSidePx)
    Fail(path, "BMP size out of range");
  if (l.bits != 8 && l.bits != 24 && l.bits != 32)
    Fail(path, std::to_string(l.bits) + " bits per pixel (8, 24 or 32 are read)");
  const bool standard_masks = compression == kBitFields && l.bits == 32 &&
                              b.size() >= kMasksAt + 12 && U32(b, kMasksAt) == 0x00ff0000u &&
                              U32(b, kMasksAt + 4) == 0x0000ff00u &&
                              U32(b, kMasksAt + 8) == 0x000000ffu;
  if (compression != kRgb && !standard_masks)
    Fail(path, "a compressed or bit-field BMP (uncompressed BGR / BGRA is read)");
  l.data_at = U32(b, 10);
  l.stride = static_cast<size_t>((l.width * l.bits + 31) / 32 * 4);
  if (l.data_at > b.size() || (b.size() - l.data_at) / l.stride < static_cast<size_t>(l.height))
    Fail(path, "truncated BMP");
  if (l.bits == 8) {
    const std::uint32_t used = U32(b, 46);
    l.palette_size = used == 0 ? 256 : used;
    l.palette_at = kFileHeaderBytes + header;
    if (l.palette_size > 256 || l.palette_at + 4 * l.palette_size > l.data_at)
      Fail(path, "bad BMP palette");
  }
  return l;
}

// Pixel (x, y), y from the top, as r g b.
std::array<unsigned char, 3> Rgb(const std::vector<unsigned char>& b,
                                 const BmpLayout& l,
                                 std::int64_t x,
                                 std::int64_t y,
                                 const std::string& path) {
  const std::int64_t row = l.top_down ? y : l.height - 1 - y;
  const size_t at = l.data_at + static_cast<size_t>(row) * l.stride;
  if (l.bits == 8) {
    const size_t index = b[at + static_cast<size_t>(x)];
    if (index >= l.palette_size) Fail(path, "a pixel indexes beyond the BMP palette");
    const size_t p = l.palette_at + 4 * index;
    return {b[p + 2], b[p + 1], b[p]};
  }
  const size_t p = at + static_cast<size_t>(x) * static_cast<size_t>(l.bits / 8);
  return {b[p + 2], b[p + 1], b[p]};
}

bool GreyPalette(const std::vector<unsigned char>& b, const BmpLayout& l) {
  if (l.bits != 8) return false;
  for (size_t i = 0; i < l.palette_size; ++i) {
    const size_t p = l.palette_at + 4 * i;
    if (b[p] != b[p + 1] || b[p] != b[p + 2]) return false;
  }
  return true;
}

void RequireChannels(const ChannelWeights& channels, const std::string& path) {
  if (!channels.given)
    Fail(path,
         "a colour image; frames.json must say which channels carry the light "
         "(\"channels\": {\"r\": 1, \"g\": -1, \"b\": 0} for a red laser)");
}

int BayerCode(const std::string& pattern) {
  if (pattern == "RGGB") return cv::COLOR_BayerRGGB2RGB;
  if (pattern == "BGGR") return cv::COLOR_BayerBGGR2RGB;
  if (pattern == "GRBG") return cv::COLOR_BayerGRBG2RGB;
  if (pattern == "GBRG") return cv::COLOR_BayerGBRG2RGB;
  throw FrameIoError("frames: Bayer pattern '" + pattern + "' (RGGB, BGGR, GRBG or GBRG)");
}

}  // namespace

void ReadBmp(const std::string& path, Frame* f, const ChannelWeights& channels) {
  const std::vector<unsigned char> b = ReadAll(path);
  const BmpLayout l = Layout(b, path);
  const bool grey = GreyPalette(b, l);
  if (!grey) RequireChannels(channels, path);
  const size_t n = static_cast<size_t>(l.width * l.height);
  std::vector<unsigned char> rgb(3 * n);
  for (std::int64_t y = 0; y < l.height; ++y)
    for (std::int64_t x = 0; x < l.width; ++x) {
      const auto p = Rgb(b, l, x, y, path);
      std::copy(p.begin(), p.end(),
                rgb.begin() + static_cast<std::ptrdiff_t>(3 * (y * l.width + x)));
    }
  f->bit_depth = 8;
  f->pixels.assign(n, 0);
  if (grey) {
    for (size_t i = 0; i < n; ++i) f->pixels[i] = rgb[3 * i];
  } else {
    Weigh(rgb.data(), channels, 8, &f->pixels);
  }
  f->aoi.width = static_cast<int>(l.width), f->aoi.height = static_cast<int>(l.height);
}

void ReadRawBayer(const std::string& path,
                  Frame* f,
                  const ChannelWeights& channels,
                  const RawBayer& raw) {
  if (!raw.given) Fail(path, "a raw frame; the manifest must give its \"raw\" layout");
  RequireChannels(channels, path);
  const int code = BayerCode(raw.pattern);
  const std::vector<unsigned char> b = ReadAll(path);
  const size_t n = base::RasterSize(raw.width, raw.height);
  const size_t bytes = raw.bit_depth > 8 ? 2 : 1;
  if (b.size() != n * bytes)
    Fail(path, "holds " + std::to_string(b.size()) + " bytes; " + std::to_string(raw.width) +
                   " x " + std::to_string(raw.height) + " samples of " + std::to_string(bytes) +
                   " byte(s) are " + std::to_string(n * bytes));
  const int full = (1 << raw.bit_depth) - 1;
  cv::Mat mosaic(raw.height, raw.width, CV_16U);
  auto* out = mosaic.ptr<std::uint16_t>();
  for (size_t i = 0; i < n; ++i) {
    out[i] = bytes == 1 ? b[i] : static_cast<std::uint16_t>(b[2 * i] | b[2 * i + 1] << 8);
    if (out[i] > full)
      Fail(path, "a sample of " + std::to_string(out[i]) + " in a " +
                     std::to_string(raw.bit_depth) +
                     "-bit mosaic (wrong bit depth or byte order?)");
  }
  cv::Mat rgb;
  cv::cvtColor(mosaic, rgb, code);
  f->bit_depth = raw.bit_depth;
  f->pixels.assign(n, 0);
  Weigh(rgb.ptr<std::uint16_t>(), channels, raw.bit_depth, &f->pixels);
  f->aoi.width = raw.width, f->aoi.height = raw.height;
}

}  // namespace mlp::probe_fw
