#pragma once
// One value per pixel from interleaved RGB samples (ChannelWeights, frame_io.h): shared by the
// colour readers (PNG, BMP, raw Bayer).

#include "mlp/probe_fw/frame_io.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace mlp::probe_fw {

/// `out` holds as many pixels as `rgb` holds triplets; a channel of positive weight at full
/// scale makes the pixel full scale (a clipped laser stays saturated whatever the weighting).
template <typename Sample>
void Weigh(const Sample* rgb,
           const ChannelWeights& w,
           int bit_depth,
           std::vector<std::uint16_t>* out) {
  const double full = (1 << bit_depth) - 1;
  const double weight[3] = {w.r, w.g, w.b};
  for (size_t i = 0; i < out->size(); ++i) {
    double v = 0.0;
    bool clipped = false;
    for (int c = 0; c < 3; ++c) {
      const double s = rgb[3 * i + static_cast<size_t>(c)];
      v += weight[c] * s;
      clipped = clipped || (weight[c] > 0 && s >= full);
    }
    v = clipped ? full : std::clamp(std::round(v), 0.0, full);
    (*out)[i] = static_cast<std::uint16_t>(v);
  }
}

}  // namespace mlp::probe_fw
