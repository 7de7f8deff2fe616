#include "mlp/geometry/profile2d.h"

#include "mlp/geometry/error.h"

#include <algorithm>
#include <cmath>

namespace mlp::geometry {
namespace {

constexpr double kJoinTolMm = 1e-9;

Vec2 Left(const Vec2& v) { return {-v.y(), v.x()}; }

// The arc's sweep [rad], > 0, from start to end in its direction.
double Sweep(const ProfileSegment& a) {
  const double t0 = std::atan2(a.start.y() - a.center.y(), a.start.x() - a.center.x());
  const double t1 = std::atan2(a.end.y() - a.center.y(), a.end.x() - a.center.x());
  double d = a.ccw ? t1 - t0 : t0 - t1;
  while (d <= 0) d += 2 * M_PI;
  return d;
}

}  // namespace

Profile2::Profile2(std::vector<ProfileSegment> segments) : segments_(std::move(segments)) {
  if (segments_.empty()) throw GeometryError(ErrorCode::kInvalidArgument, "profile: no segments");
  cumulative_.push_back(0.0);
  for (size_t k = 0; k < segments_.size(); ++k) {
    const ProfileSegment& g = segments_[k];
    if (!g.start.allFinite() || !g.end.allFinite() || !g.center.allFinite())
      throw GeometryError(ErrorCode::kNonFinite, "profile: a segment is not finite");
    if (k > 0 && (g.start - segments_[k - 1].end).norm() > kJoinTolMm)
      throw GeometryError(ErrorCode::kInvalidArgument, "profile: segment " + std::to_string(k) +
                                                           " does not start where " +
                                                           std::to_string(k - 1) + " ends");
    if (g.arc && std::abs((g.start - g.center).norm() - (g.end - g.center).norm()) > 1e-6)
      throw GeometryError(ErrorCode::kInvalidArgument,
                          "profile: arc " + std::to_string(k) + "'s ends are not on one circle");
    const double len = SegmentLength(static_cast<int>(k));
    if (!(len > 1e-9))
      throw GeometryError(ErrorCode::kInvalidArgument,
                          "profile: segment " + std::to_string(k) + " has no length");
    cumulative_.push_back(cumulative_.back() + len);
  }
}

double Profile2::SegmentLength(int k) const {
  const ProfileSegment& g = segments_[static_cast<size_t>(k)];
  return g.arc ? (g.start - g.center).norm() * Sweep(g) : (g.end - g.start).norm();
}

ProfileFoot Profile2::OnSegment(int k, double t) const {
  const ProfileSegment& g = segments_[static_cast<size_t>(k)];
  ProfileFoot f;
  f.segment = k;
  f.s = cumulative_[static_cast<size_t>(k)] + t;
  if (!g.arc) {
    const Vec2 dir = (g.end - g.start).normalized();
    f.point = g.start + t * dir;
    f.normal = Left(dir);
    return f;
  }
  const double r = (g.start - g.center).norm();
  const double a0 = std::atan2(g.start.y() - g.center.y(), g.start.x() - g.center.x());
  const double a = a0 + (g.ccw ? 1 : -1) * t / r;
  const Vec2 radial(std::cos(a), std::sin(a));
  f.point = g.center + r * radial;
  // Travelling ccw the left is towards the centre; cw, away from it.
  f.normal = g.ccw ? Vec2(-radial) : radial;
  return f;
}

ProfileFoot Profile2::At(double s) const {
  s = std::clamp(s, 0.0, Length());
  const auto it = std::upper_bound(cumulative_.begin(), cumulative_.end() - 1, s);
  const int k = std::max(0, static_cast<int>(it - cumulative_.begin()) - 1);
  return OnSegment(k, s - cumulative_[static_cast<size_t>(k)]);
}

ProfileFoot Profile2::Closest(const Vec2& p) const {
  ProfileFoot best;
  double best_d = 1e300;
  for (int k = 0; k < static_cast<int>(segments_.size()); ++k) {
    const ProfileSegment& g = segments_[static_cast<size_t>(k)];
    const double len = SegmentLength(k);
    double t = 0;
    if (!g.arc) {
      t = std::clamp((p - g.start).dot((g.end - g.start).normalized()), 0.0, len);
    } else {
      // The angle of p from the start, along the arc's direction, within its sweep, else
      // the nearer end.
      const double r = (g.start - g.center).norm();
      const double a0 = std::atan2(g.start.y() - g.center.y(), g.start.x() - g.center.x());
      const double ap = std::atan2(p.y() - g.center.y(), p.x() - g.center.x());
      double d = g.ccw ? ap - a0 : a0 - ap;
      d -= 2 * M_PI * std::floor(d / (2 * M_PI));  // [0, 2 pi)
      const double sweep = len / r;
      t = d <= sweep ? d * r : ((d - sweep) < (2 * M_PI - d) ? len : 0.0);
    }
    ProfileFoot f = OnSegment(k, t);
    const double dist = (p - f.point).norm();
    if (dist < best_d) best_d = dist, best = f;
  }
  const double side = (p - best.point).dot(best.normal);
  best.signed_distance = side >= 0 ? best_d : -best_d;
  return best;
}

}  // namespace mlp::geometry
