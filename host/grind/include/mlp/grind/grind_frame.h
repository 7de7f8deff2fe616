#pragma once
/// @file Back-lit frames of a workpiece being ground to a curve (seed 001), synthetic with
/// their truth. A telecentric camera sees the silhouette (the material dark on the back-light);
/// frames are taken with the reciprocating wheel at its top, out of view. The material is the
/// previous pass's (the nominal profile plus `stock_mm` outwards) less every section the wheel
/// has swept (wheel.h: a round nose of radius R, or a double-bevel wheel with that tip arc)
/// whose real centre is the NC's C moved by the machine's error (an offset; wear makes the
/// nose smaller; an offset inwards over-cuts).
///
/// Image: x = origin_x + u mm_per_px, y = origin_y - v mm_per_px for pixel centres (u, v):
/// y up, the material below the profile.

#include "mlp/base/input_error.h"
#include "mlp/geometry/profile2d.h"
#include "mlp/geometry/types.h"
#include "mlp/grind/wheel.h"

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace mlp::grind {

/// A measurement without result (no contour on the line C-Mi). Bad input (a job file, a camera
/// or frames that do not fit it) is a GrindInputError.
class GrindError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class GrindInputError : public base::InputError {
 public:
  using base::InputError::InputError;
};

struct GrindCamera {
  int width_px = 1024, height_px = 768;
  double mm_per_px = 0.005;
  double origin_x_mm = 0.0, origin_y_mm = 3.84;  ///< the top-left pixel's centre
  double psf_sigma_px = 0.7;
  double bright = 210, dark = 25, noise_sigma = 2.0;
  geometry::Vec2 ToMm(const geometry::Vec2& px) const {
    return {origin_x_mm + px.x() * mm_per_px, origin_y_mm - px.y() * mm_per_px};
  }
  geometry::Vec2 ToPx(const geometry::Vec2& mm) const {
    return {(mm.x() - origin_x_mm) / mm_per_px, (origin_y_mm - mm.y()) / mm_per_px};
  }
  void Validate() const;  ///< throws GrindInputError naming the field
};

/// Where the wheel's nose really was for a stroke.
struct WheelStroke {
  geometry::Vec2 center_mm = geometry::Vec2::Zero();
  double radius_mm = 0.0;
};

/// The material left: the nominal plus `stock_mm` less the wheel's section at each stroke
/// (the nose's disc, or with `bevel` the double-bevel wheel's rounded wedge).
std::vector<std::uint8_t> RenderGrindFrame(const geometry::Profile2& nominal,
                                           double stock_mm,
                                           const std::vector<WheelStroke>& strokes,
                                           const GrindCamera& camera,
                                           unsigned seed,
                                           const WheelBevel& bevel = {});

}  // namespace mlp::grind
