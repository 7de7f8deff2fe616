#pragma once
// What the renderer knows of one pixel (shared by render.cc and interreflection.cc).

#include "mlp/sim/render.h"

namespace mlp::sim {

// Everything about one pixel that does not depend on the laser column.
struct VirtualProbe::Pixel {
  bool hit = false, lit = false;
  Vec3 point_in_probe = Vec3::Zero();
  double reflectance = 0.0;     // diffuse: the shop light's and the LED frame's edges
  double laser_response = 0.0;  // brdf.h: Reflected from the projector towards the camera
  double led_response = 0.0;    // ... from the LED ring (coaxial) back to the camera
  double sheet_column = 0.0;    // the mirror's actual column whose sheet centre lights the point
};

}  // namespace mlp::sim
