#include "mlp/probe_fw/sweep.h"

#include "mlp/base/raster.h"

#include <cerrno>
#include <cmath>
#include <cstring>

#include "device_io.h"
#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <unistd.h>

namespace mlp::probe_fw {
namespace {

// Turns the laser and the LEDs off on every way out of a sweep: a failed frame must not leave
// a class 2 laser lit in the machine's workspace.
class LightsOff {
 public:
  explicit LightsOff(Projector& p) : p_(p) {}
  LightsOff(const LightsOff&) = delete;
  LightsOff& operator=(const LightsOff&) = delete;
  ~LightsOff() {
    try {
      p_.SetLaser(false);
      p_.SetLed(false);
    } catch (...) {  // a destructor must not throw; the driver's own destructor tries again
    }
  }

 private:
  Projector& p_;
};

constexpr double kColumnMatch = 1e-6;

[[noreturn]] void FailCamera(const std::string& device, const std::string& what, int err) {
  throw FrameIoError(
      device_io::Describe("camera ", device, what, err, "no camera on this machine?"));
}

// The device opened, and a V4L2 camera that streams, or FrameIoError.
int OpenCaptureDevice(const std::string& device) {
  const int fd = open(device.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) FailCamera(device, "cannot open", errno);
  v4l2_capability cap{};
  const int queried = device_io::Ioctl(fd, VIDIOC_QUERYCAP, &cap);
  const int query_errno = errno;
  if (queried < 0 || !(cap.capabilities & V4L2_CAP_VIDEO_CAPTURE) ||
      !(cap.capabilities & V4L2_CAP_STREAMING)) {
    close(fd);
    FailCamera(device, queried < 0 ? "is not a V4L2 device" : "cannot stream video capture",
               queried < 0 ? query_errno : 0);
  }
  return fd;
}

class RecordedCamera : public FrameGrabber {
 public:
  RecordedCamera(std::vector<Frame> frames, const Projector& projector)
      : frames_(std::move(frames)), projector_(projector) {}
  void Grab(Frame* frame) override {
    const ProjectorState s = projector_.State();
    if (s.led_on == s.laser_on) {
      throw FrameIoError("camera (recorded frames): nothing was recorded with the LEDs " +
                         std::string(s.led_on ? "and" : "nor") + " the laser on");
    }
    for (const Frame& f : frames_) {
      const bool lit = s.led_on
                           ? !f.IsLaser()
                           : f.IsLaser() && std::abs(f.laser_column - s.column) <= kColumnMatch;
      if (lit) {
        *frame = f;
        return;
      }
    }
    throw FrameIoError(s.led_on ? "camera (recorded frames): no LED frame was recorded"
                                : "camera (recorded frames): no frame was recorded at column " +
                                      std::to_string(s.column));
  }

 private:
  std::vector<Frame> frames_;
  const Projector& projector_;
};

class V4l2Camera : public FrameGrabber {
 public:
  V4l2Camera(const std::string& device, const SweepPlan& plan, int bit_depth)
      : device_(device), aoi_(plan.aoi), bit_depth_(bit_depth) {
    fd_ = OpenCaptureDevice(device);
    try {
      Configure(plan.exposure_us);
      StartStreaming();
    } catch (...) {
      Release();
      throw;
    }
  }
  ~V4l2Camera() override { Release(); }

  void Grab(Frame* frame) override {
    fd_set fds;
    FD_ZERO(&fds);
    FD_SET(fd_, &fds);
    timeval timeout{2, 0};  // a frame takes milliseconds; two seconds means the camera is gone
    if (select(fd_ + 1, &fds, nullptr, nullptr, &timeout) <= 0)
      Fail("delivered no frame in 2 s", errno);
    v4l2_buffer buf{};
    buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buf.memory = V4L2_MEMORY_MMAP;
    if (device_io::Ioctl(fd_, VIDIOC_DQBUF, &buf) < 0) Fail("failed to dequeue a frame", errno);
    // The driver numbers the frames it captured; a gap is frames it had no buffer for.
    if (have_sequence_ && buf.sequence > last_sequence_ + 1)
      dropped_ += buf.sequence - last_sequence_ - 1;
    last_sequence_ = buf.sequence, have_sequence_ = true;
    Frame f;
    f.aoi = aoi_;
    f.bit_depth = bit_depth_;
    f.pixels.resize(base::RasterSize(aoi_.width, aoi_.height));
    const auto* data = static_cast<const std::uint8_t*>(buffers_[buf.index].first);
    for (size_t i = 0; i < f.pixels.size(); ++i) {
      f.pixels[i] = bit_depth_ > 8
                        ? static_cast<std::uint16_t>(data[2 * i] | (data[2 * i + 1] << 8))
                        : data[i];
    }
    if (device_io::Ioctl(fd_, VIDIOC_QBUF, &buf) < 0) Fail("failed to requeue a buffer", errno);
    *frame = std::move(f);
  }
  std::uint64_t Dropped() const override { return dropped_; }

 private:
  [[noreturn]] void Fail(const std::string& what, int err) const { FailCamera(device_, what, err); }
  void Configure(double exposure_us) {
    // The sensor reads out the window only (crop), at full resolution.
    v4l2_crop crop{};
    crop.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    crop.c = {aoi_.x0, aoi_.y0, static_cast<unsigned>(aoi_.width),
              static_cast<unsigned>(aoi_.height)};
    if (device_io::Ioctl(fd_, VIDIOC_S_CROP, &crop) < 0 && errno != EINVAL && errno != ENOTTY)
      Fail("refuses the window", errno);
    v4l2_format fmt{};
    fmt.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    fmt.fmt.pix.width = static_cast<unsigned>(aoi_.width);
    fmt.fmt.pix.height = static_cast<unsigned>(aoi_.height);
    fmt.fmt.pix.pixelformat = bit_depth_ > 8 ? V4L2_PIX_FMT_Y16 : V4L2_PIX_FMT_GREY;
    fmt.fmt.pix.field = V4L2_FIELD_NONE;
    if (device_io::Ioctl(fd_, VIDIOC_S_FMT, &fmt) < 0) Fail("refuses the grey format", errno);
    if (fmt.fmt.pix.width != static_cast<unsigned>(aoi_.width) ||
        fmt.fmt.pix.height != static_cast<unsigned>(aoi_.height)) {
      Fail("cannot deliver the requested AOI size", 0);
    }
    // V4L2's absolute exposure is in units of 100 us.
    v4l2_control exposure{V4L2_CID_EXPOSURE_ABSOLUTE,
                          static_cast<std::int32_t>(std::lround(exposure_us / 100.0))};
    if (exposure.value < 1) exposure.value = 1;
    if (device_io::Ioctl(fd_, VIDIOC_S_CTRL, &exposure) < 0) Fail("refuses the exposure", errno);
  }
  void StartStreaming() {
    v4l2_requestbuffers req{};
    req.count = 4;
    req.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    req.memory = V4L2_MEMORY_MMAP;
    if (device_io::Ioctl(fd_, VIDIOC_REQBUFS, &req) < 0 || req.count < 2)
      Fail("has no mmap buffers", errno);
    for (unsigned i = 0; i < req.count; ++i) {
      v4l2_buffer buf{};
      buf.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      buf.memory = V4L2_MEMORY_MMAP;
      buf.index = i;
      if (device_io::Ioctl(fd_, VIDIOC_QUERYBUF, &buf) < 0) Fail("cannot query a buffer", errno);
      void* p = mmap(nullptr, buf.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, buf.m.offset);
      if (p == MAP_FAILED) Fail("cannot map a buffer", errno);
      buffers_.emplace_back(p, buf.length);
      if (device_io::Ioctl(fd_, VIDIOC_QBUF, &buf) < 0) Fail("cannot queue a buffer", errno);
    }
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (device_io::Ioctl(fd_, VIDIOC_STREAMON, &type) < 0) Fail("cannot start streaming", errno);
  }
  void Release() {
    if (fd_ < 0) return;
    v4l2_buf_type type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    device_io::Ioctl(fd_, VIDIOC_STREAMOFF, &type);
    for (auto& b : buffers_) munmap(b.first, b.second);
    buffers_.clear();
    close(fd_);
    fd_ = -1;
  }

  std::string device_;
  Aoi aoi_;
  int bit_depth_;
  int fd_ = -1;
  std::vector<std::pair<void*, size_t>> buffers_;
  std::uint32_t last_sequence_ = 0;
  bool have_sequence_ = false;
  std::uint64_t dropped_ = 0;
};

}  // namespace

std::vector<Frame> TakeSweep(Projector& projector, FrameGrabber& camera, const SweepPlan& plan) {
  std::vector<Frame> frames(plan.columns.size() + 1);
  const LightsOff guard(projector);
  projector.SetLaser(false);
  projector.SetLed(true);
  camera.Grab(&frames[0]);
  frames[0].laser_column = -1.0;
  projector.SetLed(false);
  projector.SetLaser(true);
  for (size_t i = 0; i < plan.columns.size(); ++i) {
    projector.SetColumn(plan.columns[i]);
    camera.Grab(&frames[i + 1]);
    frames[i + 1].laser_column = plan.columns[i];
  }
  return frames;
}

std::unique_ptr<FrameGrabber> MakeRecordedCamera(std::vector<Frame> frames,
                                                 const Projector& projector) {
  return std::make_unique<RecordedCamera>(std::move(frames), projector);
}

void CheckV4l2Camera(const std::string& device) { close(OpenCaptureDevice(device)); }

std::unique_ptr<FrameGrabber> OpenV4l2Camera(const std::string& device,
                                             const SweepPlan& plan,
                                             int bit_depth) {
  return std::make_unique<V4l2Camera>(device, plan, bit_depth);
}

}  // namespace mlp::probe_fw
