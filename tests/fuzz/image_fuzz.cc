// libFuzzer target: arbitrary bytes as an image file of each kind the firmware reads (BMP and
// PGM parsed by hand, PNG through libpng, raw Bayer through OpenCV's demosaicing). Only typed
// FrameIoErrors may come out; anything else (a crash, an ASan/UBSan report, another exception)
// is a finding. Built and run by scripts/fuzz-link.sh.

#include "mlp/probe_fw/frame_io.h"

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include <unistd.h>

using namespace mlp::probe_fw;

namespace {

void Read(const std::string& path, const uint8_t* data, size_t size, const RawBayer& raw) {
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  Frame frame;
  try {
    ReadImage(path, &frame, {true, 1.0, -1.0, 0.0}, raw);
  } catch (const FrameIoError&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string stem = "/tmp/mlp_image_fuzz_" + std::to_string(getpid());
  const RawBayer raw{true, "RGGB", 16, 12, 12};
  for (const char* ext : {".bmp", ".pgm", ".png", ".raw"}) Read(stem + ext, data, size, raw);
  return 0;
}
