// Grey and colour PNG images through libpng, directly. OpenCV's imgcodecs would do it in one call,
// but on the probe's board it brings GDAL, GDCM, OpenEXR and a hundred more libraries (190 Debian
// packages, 174 MB, for reading one PNG); libpng needs zlib alone.
//
// libpng reports errors by longjmp. The functions that call setjmp hold no C++ object that
// needs destroying between setjmp and the calls that may jump; the reader/writer objects that
// own libpng's structures live in the caller's frame, which the jump never leaves.
#include "png_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "weigh.h"
#include <png.h>

namespace mlp::probe_fw {
namespace {

constexpr png_uint_32 kMaxSidePx = 16384;

struct PngError {
  char message[256] = "";
};

extern "C" void OnPngError(png_structp png, png_const_charp message) {
  auto* error = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(error->message, sizeof error->message, "%s", message);
  png_longjmp(png, 1);
}
extern "C" void OnPngWarning(png_structp, png_const_charp) {}

struct Reader {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngError error;
  ~Reader() {
    png_destroy_read_struct(&png, &info, nullptr);
    if (file) std::fclose(file);
  }
};

struct Writer {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngError error;
  ~Writer() {
    png_destroy_write_struct(&png, &info);
    if (file) std::fclose(file);
  }
};

struct Header {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, colour_type = 0;
};

// Reads the header and sets up the transformations: grey below 8 bits widened to 8, a palette
// expanded to RGB, alpha dropped (a camera's frame has none worth keeping), 16-bit samples in the
// machine's byte order. `h->colour_type` ends as PNG_COLOR_TYPE_GRAY or PNG_COLOR_TYPE_RGB.
bool ReadHeader(Reader* r, Header* h) {
  if (setjmp(png_jmpbuf(r->png))) return false;
  png_init_io(r->png, r->file);
  png_read_info(r->png, r->info);
  png_get_IHDR(r->png, r->info, &h->width, &h->height, &h->bit_depth, &h->colour_type, nullptr,
               nullptr, nullptr);
  if (h->colour_type == PNG_COLOR_TYPE_PALETTE) {
    png_set_palette_to_rgb(r->png);
    h->bit_depth = 8;
  }
  if (h->colour_type & PNG_COLOR_MASK_ALPHA) png_set_strip_alpha(r->png);
  h->colour_type =
      (h->colour_type & PNG_COLOR_MASK_COLOR) ? PNG_COLOR_TYPE_RGB : PNG_COLOR_TYPE_GRAY;
  if (h->bit_depth < 8) png_set_expand_gray_1_2_4_to_8(r->png);
  if (h->bit_depth == 16) png_set_swap(r->png);
  png_set_interlace_handling(r->png);
  png_read_update_info(r->png, r->info);
  return true;
}

bool ReadRows(Reader* r, png_bytepp rows) {
  if (setjmp(png_jmpbuf(r->png))) return false;
  png_read_image(r->png, rows);
  png_read_end(r->png, nullptr);
  return true;
}

bool WriteRows(Writer* w, const Header& h, png_bytepp rows) {
  if (setjmp(png_jmpbuf(w->png))) return false;
  png_init_io(w->png, w->file);
  png_set_compression_level(w->png, 1);  // frames are written while capturing: speed first
  png_set_IHDR(w->png, w->info, h.width, h.height, h.bit_depth, PNG_COLOR_TYPE_GRAY,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(w->png, w->info);
  if (h.bit_depth == 16) png_set_swap(w->png);
  png_write_image(w->png, rows);
  png_write_end(w->png, nullptr);
  return true;
}

void ReadColourPng(
    Reader* r, const Header& h, const ChannelWeights& channels, const std::string& path, Frame* f) {
  const bool wide = h.bit_depth == 16;
  const size_t width = h.width, height = h.height, samples = 3 * width * height;
  std::vector<std::uint8_t> narrow(wide ? 0 : samples);
  std::vector<std::uint16_t> wide_samples(wide ? samples : 0);
  std::vector<png_bytep> rows(height);
  for (size_t y = 0; y < height; ++y) {
    rows[y] = wide ? reinterpret_cast<png_bytep>(wide_samples.data() + 3 * y * width)
                   : narrow.data() + 3 * y * width;
  }
  if (!ReadRows(r, rows.data())) throw FrameIoError("frames: " + path + ": " + r->error.message);
  // A 16-bit PNG holds a 10-, 12- or 14-bit camera's values unscaled: the manifest's depth.
  f->bit_depth = wide ? (f->bit_depth > 8 ? f->bit_depth : 16) : 8;
  f->pixels.assign(width * height, 0);
  if (wide)
    Weigh(wide_samples.data(), channels, f->bit_depth, &f->pixels);
  else
    Weigh(narrow.data(), channels, 8, &f->pixels);
  f->aoi.width = static_cast<int>(width), f->aoi.height = static_cast<int>(height);
}

}  // namespace

void ReadPng(const std::string& path, Frame* f, const ChannelWeights& channels) {
  Reader r;
  r.file = std::fopen(path.c_str(), "rb");
  if (!r.file)
    throw FrameIoError("frames: cannot open " + path + " (" + std::strerror(errno) + ")");
  r.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &r.error, OnPngError, OnPngWarning);
  if (r.png) r.info = png_create_info_struct(r.png);
  if (!r.info) throw FrameIoError("frames: out of memory reading " + path);
  Header h;
  if (!ReadHeader(&r, &h)) throw FrameIoError("frames: " + path + ": " + r.error.message);
  const bool colour = h.colour_type == PNG_COLOR_TYPE_RGB;
  if (colour && !channels.given)
    throw FrameIoError("frames: " + path +
                       ": a colour image; frames.json must say which channels carry the light "
                       "(\"channels\": {\"r\": 1, \"g\": -1, \"b\": 0} for a red laser)");
  if (h.width > kMaxSidePx || h.height > kMaxSidePx) {
    throw FrameIoError("frames: " + path + ": image too large");
  }
  if (colour) return ReadColourPng(&r, h, channels, path, f);
  const bool wide = h.bit_depth == 16;
  const size_t width = h.width, height = h.height;
  std::vector<std::uint8_t> narrow(wide ? 0 : width * height);
  f->pixels.assign(width * height, 0);
  std::vector<png_bytep> rows(height);
  for (size_t y = 0; y < height; ++y) {
    rows[y] = wide ? reinterpret_cast<png_bytep>(f->pixels.data() + y * width)
                   : narrow.data() + y * width;
  }
  if (!ReadRows(&r, rows.data())) throw FrameIoError("frames: " + path + ": " + r.error.message);
  if (!wide) {
    for (size_t i = 0; i < narrow.size(); ++i) f->pixels[i] = narrow[i];
    f->bit_depth = 8;
  }
  f->aoi.width = static_cast<int>(width), f->aoi.height = static_cast<int>(height);
}

void WritePng(const Frame& f, const std::string& path) {
  Header h;
  h.width = static_cast<png_uint_32>(f.aoi.width);
  h.height = static_cast<png_uint_32>(f.aoi.height);
  h.bit_depth = f.bit_depth > 8 ? 16 : 8;
  const size_t width = h.width;
  std::vector<std::uint8_t> narrow;
  std::vector<std::uint16_t> wide;
  std::vector<png_bytep> rows(h.height);
  if (h.bit_depth == 16) {
    wide = f.pixels;
    for (size_t y = 0; y < rows.size(); ++y) {
      rows[y] = reinterpret_cast<png_bytep>(wide.data() + y * width);
    }
  } else {
    narrow.resize(f.pixels.size());
    for (size_t i = 0; i < narrow.size(); ++i) narrow[i] = static_cast<std::uint8_t>(f.pixels[i]);
    for (size_t y = 0; y < rows.size(); ++y) rows[y] = narrow.data() + y * width;
  }
  Writer w;
  w.file = std::fopen(path.c_str(), "wb");
  if (!w.file)
    throw FrameIoError("frames: cannot write " + path + " (" + std::strerror(errno) + ")");
  w.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &w.error, OnPngError, OnPngWarning);
  if (w.png) w.info = png_create_info_struct(w.png);
  if (!w.info) throw FrameIoError("frames: out of memory writing " + path);
  if (!WriteRows(&w, h, rows.data())) {
    throw FrameIoError("frames: cannot write " + path + ": " + w.error.message);
  }
  if (std::fflush(w.file) != 0) throw FrameIoError("frames: cannot write " + path);
}

}  // namespace mlp::probe_fw
