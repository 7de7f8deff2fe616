#pragma once
/// @file The probe's light sources behind one interface: the MEMS mirror that places the laser
/// line at a projector column, the laser's enable, and the LED ring that lights the LED frame.
/// Implementations: the board's (Linux spidev for the mirror driver, GPIO character device lines
/// for the laser and the LEDs) and the virtual one (a state that virtual cameras look at).

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::probe_fw {

/// A light source that cannot be driven (a device missing, a bus error). The message names the
/// device and the reason.
class ProjectorError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ProjectorState {
  bool led_on = false;
  bool laser_on = false;
  double column = 0.0;  ///< projector column the mirror points the line at
};

class Projector {
 public:
  virtual ~Projector() = default;
  /// Moves the mirror; returns once it has settled (the driver's settling time).
  virtual void SetColumn(double column) = 0;
  virtual void SetLaser(bool on) = 0;
  virtual void SetLed(bool on) = 0;
  virtual ProjectorState State() const = 0;
  /// The widest column the mirror reaches (the projector model's column count - 1).
  virtual double MaxColumn() const = 0;
};

/// A mirror, laser and LEDs that only hold their state: what the virtual probe's camera and a
/// recorded capture look at. Counts its moves for tests.
class VirtualProjector : public Projector {
 public:
  explicit VirtualProjector(double max_column) : max_column_(max_column) {}
  void SetColumn(double column) override;
  void SetLaser(bool on) override { state_.laser_on = on; }
  void SetLed(bool on) override { state_.led_on = on; }
  ProjectorState State() const override { return state_; }
  double MaxColumn() const override { return max_column_; }
  std::uint64_t Moves() const { return moves_; }

 private:
  double max_column_;
  ProjectorState state_;
  std::uint64_t moves_ = 0;
};

/// The board's drivers. The mirror driver takes 4-byte SPI words: 0xA5 (command "set column"),
/// then the column in 1/16 column steps as u24 big-endian; the laser and LED enables are
/// output lines of a GPIO chip, driven through the kernel's character device (GPIO v2 ABI).
struct LinuxProjectorConfig {
  std::string spi_device = "/dev/spidev0.0";
  std::uint32_t spi_speed_hz = 10'000'000;
  std::string gpio_chip = "/dev/gpiochip0";
  std::uint32_t laser_line = 17;
  std::uint32_t led_line = 27;
  double max_column = 1023.0;
  double settle_us = 200.0;  ///< the mirror's step response at the driver's bandwidth
};

/// Opens the SPI device and requests the two GPIO lines as outputs, both off. Throws
/// ProjectorError naming the device that is missing or refused.
std::unique_ptr<Projector> OpenLinuxProjector(const LinuxProjectorConfig& config);

/// The mirror driver's command word for a column (the wire format above). Throws
/// ProjectorError for a column outside 0..max_column.
std::vector<std::uint8_t> MirrorCommand(double column, double max_column);

}  // namespace mlp::probe_fw
