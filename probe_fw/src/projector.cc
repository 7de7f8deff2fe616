#include "mlp/probe_fw/projector.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <thread>

#include "device_io.h"
#include <fcntl.h>
#include <linux/gpio.h>
#include <linux/spi/spidev.h>
#include <sys/ioctl.h>
#include <unistd.h>

namespace mlp::probe_fw {
namespace {

constexpr std::uint8_t kSetColumnCommand = 0xA5;
constexpr double kColumnSubsteps = 16.0;  // the driver's DAC resolves 1/16 column

[[noreturn]] void Fail(const std::string& device, const std::string& what, int err) {
  throw ProjectorError(device_io::Describe("projector: ", device, what, err,
                                           "not the probe's board, or its driver is not loaded?"));
}

using device_io::Ioctl;

class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd_ >= 0) close(fd_);
  }
  int get() const { return fd_; }
  void reset(int fd) {
    if (fd_ >= 0) close(fd_);
    fd_ = fd;
  }

 private:
  int fd_;
};

class LinuxProjector : public Projector {
 public:
  explicit LinuxProjector(const LinuxProjectorConfig& c) : config_(c) {
    spi_.reset(open(c.spi_device.c_str(), O_RDWR | O_CLOEXEC));
    if (spi_.get() < 0) Fail(c.spi_device, "cannot be opened", errno);
    std::uint8_t mode = SPI_MODE_0;
    std::uint32_t speed = c.spi_speed_hz;
    if (Ioctl(spi_.get(), SPI_IOC_WR_MODE, &mode) < 0 ||
        Ioctl(spi_.get(), SPI_IOC_WR_MAX_SPEED_HZ, &speed) < 0) {
      Fail(c.spi_device, "is not an SPI device that takes mode 0", errno);
    }
    RequestLines();
  }
  // The laser is never left on: not by a capture that failed, not by a program that stops.
  ~LinuxProjector() override {
    gpio_v2_line_values off{};
    off.mask = 0b11;
    Ioctl(lines_.get(), GPIO_V2_LINE_SET_VALUES_IOCTL, &off);
  }

  void SetColumn(double column) override {
    std::vector<std::uint8_t> word = MirrorCommand(column, config_.max_column);
    spi_ioc_transfer transfer{};
    transfer.tx_buf = reinterpret_cast<std::uintptr_t>(word.data());
    transfer.len = static_cast<std::uint32_t>(word.size());
    transfer.speed_hz = config_.spi_speed_hz;
    transfer.bits_per_word = 8;
    if (Ioctl(spi_.get(), SPI_IOC_MESSAGE(1), &transfer) < 0) {
      Fail(config_.spi_device, "refused the mirror command", errno);
    }
    std::this_thread::sleep_for(std::chrono::duration<double, std::micro>(config_.settle_us));
    state_.column = column;
  }
  void SetLaser(bool on) override {
    SetLine(kLaserBit, on);
    state_.laser_on = on;
  }
  void SetLed(bool on) override {
    SetLine(kLedBit, on);
    state_.led_on = on;
  }
  ProjectorState State() const override { return state_; }
  double MaxColumn() const override { return config_.max_column; }

 private:
  static constexpr std::uint64_t kLaserBit = 1, kLedBit = 2;  // request order: laser, LED

  void RequestLines() {
    const Fd chip(open(config_.gpio_chip.c_str(), O_RDWR | O_CLOEXEC));
    if (chip.get() < 0) Fail(config_.gpio_chip, "cannot be opened", errno);
    gpio_v2_line_request request{};
    request.offsets[0] = config_.laser_line;
    request.offsets[1] = config_.led_line;
    request.num_lines = 2;
    std::snprintf(request.consumer, sizeof request.consumer, "mlp-fw");
    request.config.flags = GPIO_V2_LINE_FLAG_OUTPUT;
    request.config.num_attrs = 1;  // both lines start low: laser and LEDs off
    request.config.attrs[0].attr.id = GPIO_V2_LINE_ATTR_ID_OUTPUT_VALUES;
    request.config.attrs[0].attr.values = 0;
    request.config.attrs[0].mask = 0b11;
    if (Ioctl(chip.get(), GPIO_V2_GET_LINE_IOCTL, &request) < 0) {
      Fail(config_.gpio_chip,
           "refused lines " + std::to_string(config_.laser_line) + " (laser) and " +
               std::to_string(config_.led_line) + " (LED) as outputs",
           errno);
    }
    lines_.reset(request.fd);
  }
  void SetLine(std::uint64_t bit, bool on) {
    gpio_v2_line_values values{};
    values.mask = bit;
    values.bits = on ? bit : 0;
    if (Ioctl(lines_.get(), GPIO_V2_LINE_SET_VALUES_IOCTL, &values) < 0) {
      Fail(config_.gpio_chip, "refused to set a line", errno);
    }
  }

  LinuxProjectorConfig config_;
  Fd spi_, lines_;
  ProjectorState state_;
};

}  // namespace

void VirtualProjector::SetColumn(double column) {
  MirrorCommand(column, max_column_);  // the same range check as the board's driver
  state_.column = column;
  ++moves_;
}

std::vector<std::uint8_t> MirrorCommand(double column, double max_column) {
  if (!(column >= 0.0 && column <= max_column)) {
    throw ProjectorError("projector: column " + std::to_string(column) + " is outside 0.." +
                         std::to_string(max_column));
  }
  const auto steps = static_cast<std::uint32_t>(std::lround(column * kColumnSubsteps));
  if (steps >= (1u << 24)) throw ProjectorError("projector: column beyond the driver's 24 bits");
  return {kSetColumnCommand, static_cast<std::uint8_t>(steps >> 16),
          static_cast<std::uint8_t>(steps >> 8), static_cast<std::uint8_t>(steps)};
}

std::unique_ptr<Projector> OpenLinuxProjector(const LinuxProjectorConfig& config) {
  return std::make_unique<LinuxProjector>(config);
}

}  // namespace mlp::probe_fw
