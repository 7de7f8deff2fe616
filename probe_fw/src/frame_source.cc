#include "mlp/probe_fw/frame_source.h"

#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <unistd.h>

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
    ReadImage(dir_ + "/" + e.file, &f);
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

// Retries ioctl on EINTR, as the V4L2 documentation's examples do.
int Xioctl(int fd, unsigned long request, void* arg) {
  int r;
  do r = ioctl(fd, request, arg);
  while (r == -1 && errno == EINTR);
  return r;
}

class V4l2Source : public FrameSource {
 public:
  V4l2Source(const std::string& device,
             const Aoi& aoi,
             int bit_depth,
             std::vector<double> columns,
             CaptureMeta meta)
      : device_(device),
        aoi_(aoi),
        bit_depth_(bit_depth),
        columns_(std::move(columns)),
        meta_(std::move(meta)) {
    fd_ = open(device.c_str(), O_RDWR | O_NONBLOCK);
    if (fd_ < 0) Fail("cannot open", errno);
    v4l2_capability cap{};
    if (Xioctl(fd_, VIDIOC_QUERYCAP, &cap) < 0) Fail("is not a V4L2 device", errno);
    if (!(cap.capabilities & V4L2_CAP_VIDEO_CAPTURE) || !(cap.capabilities & V4L2_CAP_STREAMING)) {
      Fail("cannot stream video capture", 0);
    }
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<unsigned>(aoi.width);
    fmt.fmt.pix.height = static_cast<unsigned>(aoi.height);
    fmt.fmt.pix.pixelformat = bit_depth > 8 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (Xioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) Fail("refuses the grey format", errno);
    if (fmt.fmt.pix.width != static_cast<unsigned>(aoi.width) ||
        fmt.fmt.pix.height != static_cast<unsigned>(aoi.height)) {
      Fail("cannot deliver the requested AOI size", 0);
    }
    StartStreaming();
  }
  ~V4l2Source() override {
    if (fd_ < 0) return;
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    Xioctl(fd_, VIDIOC_STREAMOFF, &type);
    for (auto& b : buffers_) munmap(b.first, b.second);
    close(fd_);
  }
  bool Next(Frame* frame) override {
    if (next_ >= columns_.size()) return false;
    fd_set fds;
    FD_ZERO(&fds);
    FD_SET(fd_, &fds);
    timeval timeout{2, 0};  // a frame takes milliseconds; two seconds means the camera is gone
    if (select(fd_ + 1, &fds, nullptr, nullptr, &timeout) <= 0)
      Fail("delivered no frame in 2 s", errno);
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (Xioctl(fd_, VIDIOC_DQBUF, &buf) < 0) Fail("failed to dequeue a frame", errno);
    Frame f;
    f.aoi = aoi_;
    f.bit_depth = bit_depth_;
    f.laser_column = columns_[next_++];
    f.pixels.resize(static_cast<size_t>(aoi_.width) * static_cast<size_t>(aoi_.height));
    const auto* data = static_cast<const std::uint8_t*>(buffers_[buf.index].first);
    for (size_t i = 0; i < f.pixels.size(); ++i) {
      f.pixels[i] = bit_depth_ > 8
                        ? static_cast<std::uint16_t>(data[2 * i] | (data[2 * i + 1] << 8))
                        : data[i];
    }
    if (Xioctl(fd_, VIDIOC_QBUF, &buf) < 0) Fail("failed to requeue a buffer", errno);
    *frame = std::move(f);
    return true;
  }
  CaptureMeta Meta() const override { return meta_; }

 private:
  [[noreturn]] void Fail(const std::string& what, int err) {
    std::string msg = "camera " + device_ + " " + what;
    if (err != 0) msg += std::string(": ") + std::strerror(err);
    if (err == ENOENT) msg += " (no camera on this machine?)";
    throw FrameIoError(msg);
  }
  void StartStreaming() {
    v4l2_requestbuffers req{};
    req.count = 4;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (Xioctl(fd_, VIDIOC_REQBUFS, &req) < 0 || req.count < 2) Fail("has no mmap buffers", errno);
    for (unsigned i = 0; i < req.count; ++i) {
      v4l2_buffer buf{};
      buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buf.memory = V4L2_MEMORY_MMAP;
      buf.index = i;
      if (Xioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) Fail("cannot query a buffer", errno);
      void* p = mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
      if (p == MAP_FAILED) Fail("cannot map a buffer", errno);
      buffers_.emplace_back(p, buf.length);
      if (Xioctl(fd_, VIDIOC_QBUF, &buf) < 0) Fail("cannot queue a buffer", errno);
    }
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (Xioctl(fd_, VIDIOC_STREAMON, &type) < 0) Fail("cannot start streaming", errno);
  }

  std::string device_;
  Aoi aoi_;
  int bit_depth_;
  std::vector<double> columns_;
  CaptureMeta meta_;
  int fd_ = -1;
  std::vector<std::pair<void*, size_t>> buffers_;
  size_t next_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> OpenDirectorySource(const std::string& dir) {
  return std::make_unique<DirectorySource>(dir);
}

std::unique_ptr<FrameSource> OpenV4l2Source(const std::string& device,
                                            const Aoi& aoi,
                                            int bit_depth,
                                            std::vector<double> laser_columns,
                                            CaptureMeta meta) {
  return std::make_unique<V4l2Source>(device, aoi, bit_depth, std::move(laser_columns),
                                      std::move(meta));
}

}  // namespace mlp::probe_fw
