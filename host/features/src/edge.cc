#include "mlp/features/edge.h"

#include "mlp/base/units.h"
#include "mlp/geometry/fit.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace mlp::features {
namespace {

using geometry::Plane;
using geometry::Vec3;

// A ray further than this from the face's normal meets it at a grazing angle: a small error in
// the ray's direction moves the point a long way.
constexpr double kMinRayCos = 0.17;  // 80 deg
// Samples per segment in the line fit: views weigh equally whatever their segment's length.
constexpr int kSamplesPerSegment = 11;

Vec3 OnFace(const Vec3& camera, const Vec3& ray, const Plane& face, const std::string& id) {
  const double along = ray.dot(face.normal);
  if (!(std::abs(along) >= kMinRayCos))
    throw FeatureError("edge of capture " + id + ": its rays graze the face (view it from above)");
  const double t = (face.point - camera).dot(face.normal) / along;
  if (!(t > 0.0)) throw FeatureError("edge of capture " + id + ": the face is behind the camera");
  return camera + t * ray;
}

// Into the material, in the face: the lit side of the sight plane.
Vec3 IntoMaterial(const EdgeView& v, const Plane& face) {
  const Vec3 m = v.normal_mcs - face.normal * face.normal.dot(v.normal_mcs);
  if (!(m.norm() > kMinRayCos))
    throw FeatureError("edge of capture " + v.capture_id + ": seen edge-on to the face");
  return m.normalized();
}

// Sample i of kSamplesPerSegment along a segment: the line's fit and its uncertainty use
// the same ones.
Vec3 Sample(const EdgeMeasurement::Segment& s, int i) {
  return s.first_mcs + (s.last_mcs - s.first_mcs) * i / (kSamplesPerSegment - 1.0);
}

geometry::Line3 LineThrough(const std::vector<EdgeMeasurement::Segment>& segments) {
  if (segments.size() == 1) {
    const auto& s = segments.front();
    if (!((s.last_mcs - s.first_mcs).norm() > 0.0))
      throw FeatureError("edge: its segment has no length");
    return {0.5 * (s.first_mcs + s.last_mcs), (s.last_mcs - s.first_mcs).normalized()};
  }
  geometry::Points3 samples(3, static_cast<Eigen::Index>(kSamplesPerSegment * segments.size()));
  Eigen::Index k = 0;
  for (const auto& s : segments)
    for (int i = 0; i < kSamplesPerSegment; ++i) samples.col(k++) = Sample(s, i);
  return geometry::FitLine3(samples).shape;
}

struct EdgeU {
  double offset_mm = 0.0, angle_rad = 0.0;
};

// The line's across-offset at `at_mm` along it and its angle, as linear functions of each
// view's own across-offset (at its segment's middle) and turn, through LineThrough's fit (its
// samples, equal weights: across y(s) = mean + slope (s - mean s); one view's samples give
// its own segment back); their variances summed (views independent), the face's height term
// added (common to every view, so its across-shifts add before squaring).
EdgeU Uncertainty(const EdgeMeasurement& m, double at_mm, double face_height_u_mm) {
  const Vec3 d = m.line_mcs.direction;
  std::vector<double> s;  // every sample's position along the line
  for (const auto& g : m.segments_mcs)
    for (int i = 0; i < kSamplesPerSegment; ++i)
      s.push_back((Sample(g, i) - m.line_mcs.point).dot(d));
  double mean = 0, spread = 0;
  for (double x : s) mean += x / static_cast<double>(s.size());
  for (double x : s) spread += (x - mean) * (x - mean);
  double var_offset = 0, var_slope = 0, face_offset = 0, face_slope = 0;
  for (size_t k = 0; k < m.segments_mcs.size(); ++k) {
    const auto& g = m.segments_mcs[k];
    const double length_mm = (g.last_mcs - g.first_mcs).norm();
    const double points = std::max(2, g.points);
    const double u_across = g.rms_px / std::sqrt(points) * length_mm / points;
    const double u_turn = g.rms_px * std::sqrt(12.0) / std::pow(points, 1.5);
    const double middle = (0.5 * (g.first_mcs + g.last_mcs) - m.line_mcs.point).dot(d);
    double c_offset[2] = {0, 0}, c_slope[2] = {0, 0};  // per (own offset, own turn)
    for (int i = 0; i < kSamplesPerSegment; ++i) {
      const double x = s[k * kSamplesPerSegment + static_cast<size_t>(i)];
      const double w_offset = 1.0 / static_cast<double>(s.size()) +
                              (spread > 0 ? (at_mm - mean) * (x - mean) / spread : 0);
      const double w_slope = spread > 0 ? (x - mean) / spread : 0;
      c_offset[0] += w_offset, c_offset[1] += w_offset * (x - middle);
      c_slope[0] += w_slope, c_slope[1] += w_slope * (x - middle);
    }
    var_offset += std::pow(c_offset[0] * u_across, 2) + std::pow(c_offset[1] * u_turn, 2);
    var_slope += std::pow(c_slope[0] * u_across, 2) + std::pow(c_slope[1] * u_turn, 2);
    face_offset += c_offset[0] * g.across_per_height * face_height_u_mm;
    face_slope += c_slope[0] * g.across_per_height * face_height_u_mm;
  }
  return {std::sqrt(var_offset + face_offset * face_offset),
          std::sqrt(var_slope + face_slope * face_slope)};
}

}  // namespace

EdgeView EdgeViewInMcs(const base::EdgeSight& s,
                       const geometry::Pose3& mcs_from_probe,
                       const std::string& capture_id) {
  EdgeView v;
  v.capture_id = capture_id;
  v.camera_mcs = mcs_from_probe.translation();  // the probe frame is the camera's
  v.normal_mcs = mcs_from_probe.linear() * s.normal_in_probe;
  v.first_ray_mcs = mcs_from_probe.linear() * s.first_ray_in_probe;
  v.last_ray_mcs = mcs_from_probe.linear() * s.last_ray_in_probe;
  v.rms_px = s.rms_px;
  v.points = static_cast<int>(s.points);
  return v;
}

EdgeMeasurement MeasureEdge(const std::vector<EdgeView>& views, const Plane& face_in) {
  if (views.empty()) throw FeatureError("edge: no capture with an edge");
  Plane face = face_in;
  face.normal.normalize();
  EdgeMeasurement m;
  const Vec3 first = IntoMaterial(views.front(), face);
  Vec3 material = Vec3::Zero();
  for (const EdgeView& v : views) {
    const Vec3 into = IntoMaterial(v, face);
    if (!(into.dot(first) > 0.9))
      throw FeatureError("edge: capture " + v.capture_id +
                         " sees the lit face on the other side of the edge from capture " +
                         views.front().capture_id);
    const Vec3 mid_ray = (v.first_ray_mcs + v.last_ray_mcs).normalized();
    m.segments_mcs.push_back({OnFace(v.camera_mcs, v.first_ray_mcs, face, v.capture_id),
                              OnFace(v.camera_mcs, v.last_ray_mcs, face, v.capture_id), v.points,
                              v.rms_px,
                              // The face raised by h meets the ray h / (ray . n) further
                              // along it: its in-face part, seen across the edge.
                              mid_ray.dot(into) / mid_ray.dot(face.normal)});
    material += into;
    m.points += v.points;
    m.rms_px = std::max(m.rms_px, v.rms_px);
  }
  m.into_material_mcs = material.normalized();
  m.line_mcs = LineThrough(m.segments_mcs);
  const Vec3 x = m.into_material_mcs.cross(face.normal);
  if (m.line_mcs.direction.dot(x) < 0.0) m.line_mcs.direction = -m.line_mcs.direction;
  double lo = 1e300, hi = -1e300;
  for (const auto& s : m.segments_mcs) {
    for (const Vec3* p : {&s.first_mcs, &s.last_mcs}) {
      const Vec3 d = *p - m.line_mcs.point;
      const double t = d.dot(m.line_mcs.direction);
      lo = std::min(lo, t), hi = std::max(hi, t);
      m.straightness_mm = std::max(m.straightness_mm, (d - t * m.line_mcs.direction).norm());
    }
  }
  m.span_mm = hi - lo;
  m.views = static_cast<int>(views.size());
  return m;
}

Vec3 EdgeNominal::Direction() const {
  return face.normal_mcs.normalized().cross(Outward()).normalized();
}

Vec3 EdgeNominal::Outward() const {
  const Vec3 n = face.normal_mcs.normalized();
  return (wall_normal_mcs - n * n.dot(wall_normal_mcs)).normalized();
}

void EdgeNominal::Check() const {
  const Vec3 n = face.normal_mcs.normalized();
  if (!(face.normal_mcs.norm() > 0.0) ||
      !((wall_normal_mcs - n * n.dot(wall_normal_mcs)).norm() > 0.5 * wall_normal_mcs.norm()))
    throw FeatureError("edge: the wall's normal must lie across the face (within 60 deg of it)");
  if (!(length_mm >= 0.0 && length_mm <= 2000.0))
    throw FeatureError("edge: length_mm must be in 0..2000");
  if (views < 1 || views > 8) throw FeatureError("edge: views must be 1..8");
}

EdgeDeviation CompareEdge(const EdgeMeasurement& m, const EdgeNominal& n, double face_height_u_mm) {
  const Vec3 d = m.line_mcs.direction;
  EdgeDeviation e;
  e.found_mcs = m.line_mcs.point + d * d.dot(n.point_mcs - m.line_mcs.point);
  e.offset_mm = (e.found_mcs - n.point_mcs).dot(n.Outward());
  const Vec3 nominal = n.Direction();
  const Vec3 face = n.face.normal_mcs.normalized();
  e.angle_deg = std::atan2(nominal.cross(d).dot(face), std::abs(nominal.dot(d))) * base::kDegPerRad;
  const EdgeU u = Uncertainty(m, d.dot(n.point_mcs - m.line_mcs.point), face_height_u_mm);
  e.offset_u_mm = u.offset_mm * std::abs(m.into_material_mcs.dot(n.Outward()));
  e.angle_u_deg = u.angle_rad * base::kDegPerRad;
  return e;
}

}  // namespace mlp::features
