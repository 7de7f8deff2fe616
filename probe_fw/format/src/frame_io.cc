#include "mlp/probe_fw/frame_io.h"

#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"
#include "mlp/base/raster.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "bmp_io.h"
#include "png_io.h"

namespace mlp::probe_fw {
namespace {

namespace jf = base::json_fields;
using nlohmann::json;

[[noreturn]] void Fail(const std::string& what) { throw FrameIoError("frames: " + what); }

std::string Extension(const std::string& path) {
  return std::filesystem::path(path).extension().string();
}

void WritePgm(const Frame& f, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  const int maxval = (1 << f.bit_depth) - 1;
  out << "P5\n" << f.aoi.width << " " << f.aoi.height << "\n" << maxval << "\n";
  if (maxval < 256) {
    for (std::uint16_t v : f.pixels) out.put(static_cast<char>(v));
  } else {
    for (std::uint16_t v : f.pixels)
      out.put(static_cast<char>(v >> 8)), out.put(static_cast<char>(v & 0xff));
  }
  if (!out) Fail("cannot write " + path);
}

// Skips whitespace and '#' comments between PGM header fields (Netpbm's definition).
int HeaderInt(std::istream& in, const std::string& path) {
  int value = -1;
  while (in >> std::ws && in.peek() == '#') in.ignore(1 << 20, '\n');
  if (!(in >> value) || value <= 0) Fail(path + ": bad PGM header");
  return value;
}

void ReadPgm(const std::string& path, Frame* f) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail("cannot open " + path);
  std::string magic;
  in >> magic;
  if (magic != "P5") Fail(path + ": not a binary PGM (P5)");
  const int w = HeaderInt(in, path), h = HeaderInt(in, path), maxval = HeaderInt(in, path);
  if (w > 16384 || h > 16384 || maxval > 65535) Fail(path + ": image too large");
  in.get();  // the single whitespace after maxval
  f->aoi.width = w, f->aoi.height = h;
  f->bit_depth = std::max(8, static_cast<int>(std::ceil(std::log2(maxval + 1.0))));
  f->pixels.resize(static_cast<size_t>(w) * static_cast<size_t>(h));
  // The raster in one read (per-byte istream::get cost 60 instructions a pixel, more than the
  // stripe extraction): 1 byte per pixel, or 2 big-endian bytes when maxval > 255 (netpbm).
  const size_t bytes_per_pixel = maxval < 256 ? 1 : 2;
  std::vector<unsigned char> raster(f->pixels.size() * bytes_per_pixel);
  in.read(reinterpret_cast<char*>(raster.data()), static_cast<std::streamsize>(raster.size()));
  if (!in) Fail(path + ": truncated PGM");
  for (size_t i = 0; i < f->pixels.size(); ++i) {
    f->pixels[i] = bytes_per_pixel == 1
                       ? raster[i]
                       : static_cast<std::uint16_t>((raster[2 * i] << 8) | raster[2 * i + 1]);
  }
}

ChannelWeights ParseChannels(const json& c, const std::string& where) {
  if (!c.is_object()) Fail(where + ".channels must be {\"r\": w, \"g\": w, \"b\": w}");
  ChannelWeights w;
  w.given = true;
  w.r = jf::Number<FrameIoError>(c, "r", where + ".channels");
  w.g = jf::Number<FrameIoError>(c, "g", where + ".channels");
  w.b = jf::Number<FrameIoError>(c, "b", where + ".channels");
  for (double v : {w.r, w.g, w.b}) {
    if (!(std::abs(v) <= 16.0)) Fail(where + ".channels: each weight within [-16, 16]");
  }
  if (!(w.r > 0 || w.g > 0 || w.b > 0)) Fail(where + ".channels: no channel has a positive weight");
  return w;
}

}  // namespace

RawBayer ParseRawBayer(const json& j, const std::string& where) {
  if (!j.is_object()) Fail(where + " must be {\"pattern\", \"width\", \"height\", \"bit_depth\"}");
  RawBayer r;
  r.given = true;
  r.pattern = jf::Text<FrameIoError>(j, "pattern", where);
  r.width = jf::Integer<FrameIoError>(j, "width", where);
  r.height = jf::Integer<FrameIoError>(j, "height", where);
  r.bit_depth = jf::Integer<FrameIoError>(j, "bit_depth", where);
  if (r.pattern != "RGGB" && r.pattern != "BGGR" && r.pattern != "GRBG" && r.pattern != "GBRG")
    Fail(where + ".pattern must be RGGB, BGGR, GRBG or GBRG");
  if (r.width < 2 || r.height < 2 || r.width > 16384 || r.height > 16384 || r.bit_depth < 8 ||
      r.bit_depth > 16)
    Fail(where + ": width and height 2..16384, bit_depth 8..16");
  return r;
}

void WriteImage(const Frame& f, const std::string& path) {
  if (f.pixels.size() != base::RasterSize(f.aoi.width, f.aoi.height)) {
    Fail("frame size does not match its AOI");
  }
  const std::string ext = Extension(path);
  if (ext == ".pgm") return WritePgm(f, path);
  if (ext != ".png") Fail(path + ": use .pgm or .png");
  WritePng(f, path);
}

void ReadImage(const std::string& path,
               Frame* f,
               const ChannelWeights& channels,
               const RawBayer& raw) {
  const std::string ext = Extension(path);
  if (ext == ".pgm") return ReadPgm(path, f);
  if (ext == ".bmp") return ReadBmp(path, f, channels);
  if (ext == ".raw") return ReadRawBayer(path, f, channels, raw);
  if (ext != ".png") Fail(path + ": use .pgm, .png, .bmp or .raw");
  ReadPng(path, f, channels);
}

void WriteCaptureDir(const std::string& dir,
                     const CaptureMeta& meta,
                     const std::vector<Frame>& frames,
                     const std::string& extension) {
  std::filesystem::create_directories(dir);
  nlohmann::ordered_json manifest;
  manifest["format"] = "mlprobe-frames/1";
  manifest["probe_serial"] = meta.probe_serial;
  manifest["calibration_id"] = meta.calibration_id;
  manifest["capture_id"] = meta.capture_id;
  manifest["frames"] = nlohmann::ordered_json::array();
  int laser_index = 0;
  for (const Frame& f : frames) {
    char name[64];
    if (f.IsLaser())
      std::snprintf(name, sizeof name, "laser_%04d%s", laser_index++, extension.c_str());
    else
      std::snprintf(name, sizeof name, "led%s", extension.c_str());
    WriteImage(f, dir + "/" + name);
    manifest["frames"].push_back({{"file", name},
                                  {"laser_column", f.laser_column},
                                  {"aoi", {f.aoi.x0, f.aoi.y0, f.aoi.width, f.aoi.height}},
                                  {"bit_depth", f.bit_depth}});
  }
  try {
    base::WriteFileAtomically(dir + "/frames.json", manifest.dump(1) + "\n");
  } catch (const base::FileError& e) {
    Fail(e.what());
  }
}

CaptureManifest ReadCaptureManifest(const std::string& dir) {
  if (!std::filesystem::exists(dir + "/frames.json")) Fail("no frames.json in " + dir);
  const json j = jf::ParseDocument<FrameIoError>(
      base::ReadFileAs<FrameIoError>(dir + "/frames.json", "frames: "), "mlprobe-frames/1",
      "frames.json");
  CaptureManifest m;
  m.meta.probe_serial = jf::Text<FrameIoError>(j, "probe_serial", "frames.json");
  m.meta.calibration_id = jf::Text<FrameIoError>(j, "calibration_id", "frames.json");
  m.meta.capture_id = jf::Text<FrameIoError>(j, "capture_id", "frames.json");
  if (!j.contains("frames") || !j.at("frames").is_array())
    Fail("frames.json: frames must be an array");
  for (size_t i = 0; i < j.at("frames").size(); ++i) {
    const json& e = j.at("frames")[i];
    const std::string where = "frames.json: frames[" + std::to_string(i) + "]";
    CaptureManifest::Entry entry;
    entry.file = jf::Text<FrameIoError>(e, "file", where);
    if (entry.file.find('/') != std::string::npos || entry.file.find("..") != std::string::npos) {
      Fail(where + ".file must be a plain file name in the capture directory");
    }
    entry.laser_column = jf::Number<FrameIoError>(e, "laser_column", where);
    entry.bit_depth = jf::Integer<FrameIoError>(e, "bit_depth", where);
    if (!e.contains("aoi") || !e.at("aoi").is_array() || e.at("aoi").size() != 4) {
      Fail(where + ".aoi must be [x0, y0, width, height]");
    }
    const auto& a = e.at("aoi");
    for (int k = 0; k < 4; ++k) {
      if (!a[k].is_number_integer()) Fail(where + ".aoi must hold integers");
    }
    entry.aoi = {a[0].get<int>(), a[1].get<int>(), a[2].get<int>(), a[3].get<int>()};
    if (e.contains("channels")) entry.channels = ParseChannels(e.at("channels"), where);
    if (e.contains("raw")) entry.raw = ParseRawBayer(e.at("raw"), where + ".raw");
    m.frames.push_back(entry);
  }
  return m;
}

}  // namespace mlp::probe_fw
