#pragma once
/// @file One camera frame as the firmware sees it: a window (area of interest, AOI) of the sensor
/// read out at `bit_depth`, and what the projector did during the exposure.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace mlp::probe_fw {

/// Sensor window read out [px]; cameras read out only this window (hardware AOI).
struct Aoi {
  int x0 = 0, y0 = 0, width = 0, height = 0;
};

struct Frame {
  Aoi aoi;
  int bit_depth = 8;
  /// Projector column lit during the exposure; negative for the LED-lit frame.
  double laser_column = -1.0;
  std::vector<std::uint16_t> pixels;  ///< row-major, aoi.width x aoi.height

  std::uint16_t At(int x_in_aoi, int y_in_aoi) const {
    return pixels[static_cast<std::size_t>(y_in_aoi) * static_cast<std::size_t>(aoi.width) +
                  static_cast<std::size_t>(x_in_aoi)];
  }
  bool IsLaser() const { return laser_column >= 0.0; }
};

}  // namespace mlp::probe_fw
