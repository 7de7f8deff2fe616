#include "mlp/probe_fw/frame_source.h"

namespace mlp::probe_fw {
namespace {

class DirectorySource : public FrameSource {
 public:
  explicit DirectorySource(std::string dir)
      : dir_(std::move(dir)), manifest_(ReadCaptureManifest(dir_)) {}
  bool Next(Frame* frame) override {
    if (next_ >= manifest_.frames.size()) return false;
    const auto& e = manifest_.frames[next_++];
    Frame f;
    f.bit_depth = e.bit_depth;  // a 16-bit colour PNG of a 12-bit camera: full scale 4095
    ReadImage(dir_ + "/" + e.file, &f, e.channels, e.raw);
    if (f.aoi.width != e.aoi.width || f.aoi.height != e.aoi.height) {
      throw FrameIoError("frames: " + e.file + " is not the size its manifest entry says");
    }
    f.aoi = e.aoi;
    f.bit_depth = e.bit_depth;
    f.laser_column = e.laser_column;
    *frame = std::move(f);
    return true;
  }
  CaptureMeta Meta() const override { return manifest_.meta; }

 private:
  std::string dir_;
  CaptureManifest manifest_;
  size_t next_ = 0;
};

class FrameList : public FrameSource {
 public:
  FrameList(std::vector<Frame> frames, CaptureMeta meta)
      : frames_(std::move(frames)), meta_(std::move(meta)) {}
  bool Next(Frame* frame) override {
    if (next_ >= frames_.size()) return false;
    *frame = std::move(frames_[next_++]);
    return true;
  }
  CaptureMeta Meta() const override { return meta_; }

 private:
  std::vector<Frame> frames_;
  CaptureMeta meta_;
  size_t next_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> OpenDirectorySource(const std::string& dir) {
  return std::make_unique<DirectorySource>(dir);
}

std::unique_ptr<FrameSource> MakeFrameList(std::vector<Frame> frames, CaptureMeta meta) {
  return std::make_unique<FrameList>(std::move(frames), std::move(meta));
}

}  // namespace mlp::probe_fw
