#include "mlp/grind/wheel.h"

#include "mlp/base/units.h"
#include "mlp/grind/grind_frame.h"

#include <algorithm>
#include <cmath>

namespace mlp::grind {

using geometry::Vec2;

void WheelBevel::Validate() const {
  if (!on) return;
  if (!(half_angle_deg >= 0 && half_angle_deg <= 80))
    throw GrindInputError("grind wheel: the bevel's half angle must be 0..80 deg");
  if (!tip_dir.allFinite() || !(tip_dir.norm() > 0.5 && tip_dir.norm() < 2))
    throw GrindInputError("grind wheel: tip_dir must be a direction [x, y] (a unit vector)");
}

WheelSection::WheelSection(double r, const WheelBevel& b) : r_(r), bevel_(b.on) {
  b.Validate();
  axis_ = b.on ? Vec2(-b.tip_dir.normalized()) : Vec2(Vec2::UnitY());
  across_ = Vec2(-axis_.y(), axis_.x());
  cos_b_ = std::cos(b.half_angle_deg / base::kDegPerRad);
  sin_b_ = std::sin(b.half_angle_deg / base::kDegPerRad);
}

Vec2 WheelSection::Local(const Vec2& p) const { return {p.dot(axis_), p.dot(across_)}; }

// In the wedge's frame (h along the axis, q across, |q| by symmetry) the flank on q's side is
// the line through the tangent point r (-sin b, cos b) along (cos b, sin b): a point whose
// projection on that direction is positive is nearest the flank (distance from its line),
// else nearest the arc (distance from the circle). Exact on both sides of the edge.
bool WheelSection::NearestOnArc(const Vec2& p) const {
  if (!bevel_) return true;
  const Vec2 l = Local(p);
  return l.x() * cos_b_ + std::abs(l.y()) * sin_b_ <= 0;
}

double WheelSection::SignedDistanceMm(const Vec2& p) const {
  if (NearestOnArc(p)) return p.norm() - r_;
  const Vec2 l = Local(p);
  return -l.x() * sin_b_ + std::abs(l.y()) * cos_b_ - r_;
}

std::vector<double> WheelSection::Crossings(const Vec2& p, const Vec2& u) const {
  std::vector<double> t;
  // The circle |p + t u| = r, where its points are on the arc.
  const double b = p.dot(u), disc = b * b - p.squaredNorm() + r_ * r_;
  if (disc >= 0)
    for (const double root : {-b - std::sqrt(disc), -b + std::sqrt(disc)})
      if (NearestOnArc(p + root * u)) t.push_back(root);
  // Each flank's line (x . n = r, n its outward normal), where its points are on the flank.
  if (bevel_)
    for (const double side : {-1.0, 1.0}) {
      const Vec2 n = -sin_b_ * axis_ + side * cos_b_ * across_;
      const Vec2 along = cos_b_ * axis_ + side * sin_b_ * across_;
      const double un = u.dot(n);
      if (std::abs(un) < 1e-12) continue;
      const double root = (r_ - p.dot(n)) / un;
      if ((p + root * u).dot(along) > 0) t.push_back(root);
    }
  std::sort(t.begin(), t.end());
  t.erase(
      std::unique(t.begin(), t.end(), [](double a, double c) { return std::abs(a - c) < 1e-12; }),
      t.end());
  return t;
}

}  // namespace mlp::grind
