#include "mlp/sim/brdf.h"

#include <algorithm>
#include <cmath>

namespace mlp::sim {
double SmithG1(double cos_theta, double alpha2) {
  return 2.0 * cos_theta / (cos_theta + std::sqrt(alpha2 + (1.0 - alpha2) * cos_theta * cos_theta));
}

double SchlickFresnel(double f0, double cos_h) {
  const double c = 1.0 - std::clamp(cos_h, 0.0, 1.0);
  return f0 + (1.0 - f0) * c * c * c * c * c;
}

double Reflected(double diffuse,
                 const Gloss& gloss,
                 const Vec3& n,
                 const Vec3& to_light,
                 const Vec3& to_viewer) {
  const double cos_l = n.dot(to_light), cos_v = n.dot(to_viewer);
  if (cos_l <= 0.0 || cos_v <= 0.0) return 0.0;
  double out = diffuse * cos_l;
  if (gloss.specular_f0 <= 0.0) return out;
  const Vec3 h = (to_light + to_viewer).normalized();
  const double cos_h = std::clamp(n.dot(h), 0.0, 1.0);
  const double a2 = gloss.roughness * gloss.roughness;
  const double k = cos_h * cos_h * (a2 - 1.0) + 1.0;
  const double facets = a2 / (M_PI * k * k);  // GGX D(h), Walter et al. eq. 33
  const double masking = SmithG1(cos_l, a2) * SmithG1(cos_v, a2);
  const double fresnel = SchlickFresnel(gloss.specular_f0, h.dot(to_viewer));
  // pi f_s cos_l with f_s = D G F / (4 cos_l cos_v): the cos_l cancels.
  return out + M_PI * facets * masking * fresnel / (4.0 * cos_v);
}

}  // namespace mlp::sim
