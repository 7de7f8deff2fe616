#pragma once
// Synthetic clouds of known features for the feature tests: surfaces sampled at random with
// Gaussian noise along their normals (what a triangulating probe's error looks like), seeded.

#include "mlp/geometry/types.h"

#include <cmath>
#include <random>
#include <vector>

namespace mlp::features::test {

using geometry::Vec3;

class CloudMaker {
 public:
  CloudMaker(unsigned seed, double noise_mm) : rng_(seed), noise_(0.0, noise_mm) {}

  // A rectangle of the plane through `origin` spanned by unit u and v: [0, su] x [0, sv].
  void Patch(const Vec3& origin, const Vec3& u, const Vec3& v, double su, double sv, int count) {
    std::uniform_real_distribution<double> a(0, su), b(0, sv);
    const Vec3 normal = u.cross(v).normalized();
    for (int i = 0; i < count; ++i) {
      const double t_v = b(rng_);  // the last term's draw first: tests/seeded_draw.h
      const double t_u = a(rng_);
      Add(origin + t_u * u + t_v * v, normal);
    }
  }

  // The wall of a vertical cylinder (axis +Z) from z0 to z1, angles a0..a1 [deg].
  void Wall(double cx, double cy, double r, double z0, double z1, double a0, double a1, int count) {
    std::uniform_real_distribution<double> angle(a0 * M_PI / 180, a1 * M_PI / 180), z(z0, z1);
    for (int i = 0; i < count; ++i) {
      const double t = angle(rng_);
      const Vec3 radial(std::cos(t), std::sin(t), 0);
      Add(Vec3(cx, cy, z(rng_)) + r * radial, radial);
    }
  }

  void Add(const Vec3& on_surface, const Vec3& unit_normal) {
    points_.push_back(on_surface + noise_(rng_) * unit_normal);
  }

  geometry::Points3 Cloud() const {
    geometry::Points3 m(3, static_cast<Eigen::Index>(points_.size()));
    for (size_t i = 0; i < points_.size(); ++i) m.col(static_cast<Eigen::Index>(i)) = points_[i];
    return m;
  }

  std::mt19937& rng() { return rng_; }

 private:
  std::mt19937 rng_;
  std::normal_distribution<double> noise_;
  std::vector<Vec3> points_;
};

// Unit vector at `deg` in the XY plane.
inline Vec3 Dir(double deg) {
  return Vec3(std::cos(deg * M_PI / 180), std::sin(deg * M_PI / 180), 0);
}

}  // namespace mlp::features::test
