#include "mlp/features/plan.h"

#include "mlp/base/units.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace mlp::features {
namespace {

using geometry::Pose3;
using geometry::Vec3;

constexpr int kPatchSteps = 5;  // patch points per side: its corners, edges and middle

Vec3 Across(const Vec3& axis, const Vec3& hint) {
  const Vec3 x = hint - axis.dot(hint) * axis;
  return x.norm() > 0.1 ? Vec3(x.normalized()) : Vec3(axis.unitOrthogonal());
}

// The camera frame aimed at `aim` along `view` from `standoff`, its x axis towards `x_hint`.
Pose3 CameraAt(const Vec3& aim, const Vec3& view, const Vec3& x_hint, double standoff) {
  const Vec3 z = view.normalized(), x = Across(z, x_hint), y = z.cross(x);
  Pose3 p = Pose3::Identity();
  p.linear().col(0) = x, p.linear().col(1) = y, p.linear().col(2) = z;
  p.translation() = aim - standoff * z;
  return p;
}

// Points of a flat patch: centre +- half_u along u, +- half_v along v.
geometry::Points3 FlatPatch(const Vec3& c, const Vec3& u, const Vec3& v, double hu, double hv) {
  geometry::Points3 p(3, kPatchSteps * kPatchSteps);
  for (int i = 0; i < kPatchSteps; ++i)
    for (int j = 0; j < kPatchSteps; ++j) {
      const double a = -1 + 2.0 * i / (kPatchSteps - 1), b = -1 + 2.0 * j / (kPatchSteps - 1);
      p.col(i * kPatchSteps + j) = c + a * hu * u + b * hv * v;
    }
  return p;
}

// A wall seen from above: `n_out` its normal into the air, `up` along the wall out of the
// material; the view is tilted `wall_tilt_deg` from -up towards the wall.
ViewTarget WallView(const std::string& id,
                    const Vec3& at,
                    const Vec3& n_out,
                    const Vec3& up,
                    double half_depth,
                    const PlanOptions& o) {
  const double t = o.wall_tilt_deg / base::kDegPerRad;
  const Vec3 view = -std::sin(t) * n_out - std::cos(t) * up;
  ViewTarget v;
  v.id = id;
  v.mcs_from_camera = CameraAt(at, view, n_out, o.standoff_mm);
  v.patch_mcs = FlatPatch(at, up.cross(n_out).normalized(), up, o.patch_mm / 2, half_depth);
  return v;
}

std::string Num(double v) {
  char s[32];
  std::snprintf(s, sizeof s, "%.2f", v);
  return s;
}

}  // namespace

void PlanOptions::Check() const {
  auto need = [](bool ok, const char* what) {
    if (!ok) throw FeatureError(std::string("plan: ") + what);
  };
  need(standoff_mm > 10 && standoff_mm < 1000, "standoff_mm must be in 10..1000");
  need(wall_tilt_deg >= 5 && wall_tilt_deg <= 80, "wall_tilt_deg must be in 5..80");
  need(patch_mm > 0.5 && patch_mm <= 100, "patch_mm must be in 0.5..100");
  need(aoi_margin_px >= 0 && column_margin >= 0, "margins must be >= 0");
  need(column_step > 0, "column_step must be > 0");
  need(views_per_circle >= 3 && views_per_circle <= 24, "views_per_circle must be in 3..24");
}

std::vector<ViewTarget> FaceViews(const std::string& id,
                                  const PlaneNominal& n,
                                  const PlanOptions& o) {
  const Vec3 normal = n.normal_mcs.normalized();
  const Vec3 u = Across(normal, Vec3::UnitX()), v = normal.cross(u);
  const double half = std::min(o.patch_mm / 2, n.within_mm);
  ViewTarget t;
  t.id = id;
  t.mcs_from_camera = CameraAt(n.point_mcs, -normal, u, o.standoff_mm);
  t.patch_mcs = FlatPatch(n.point_mcs, u, v, half, half);
  return {t};
}

std::vector<ViewTarget> EdgeViews(const std::string& id,
                                  const EdgeNominal& n,
                                  const PlanOptions& o) {
  n.Check();
  const Vec3 normal = n.face.normal_mcs.normalized(), along = n.Direction();
  std::vector<ViewTarget> views;
  for (int k = 0; k < n.views; ++k) {
    const double s = n.views == 1 ? 0.0 : n.length_mm * (k / (n.views - 1.0) - 0.5);
    const Vec3 at = n.point_mcs + s * along;
    ViewTarget t;
    t.id = id + "_" + std::to_string(k + 1);
    t.mcs_from_camera = CameraAt(at, -normal, along, o.standoff_mm);
    t.patch_mcs = FlatPatch(at, along, n.Outward(), o.patch_mm / 2, o.patch_mm / 2);
    t.edge_hint_mcs = at;
    views.push_back(t);
  }
  return views;
}

std::vector<ViewTarget> BoreViews(const std::string& id,
                                  const BoreNominal& n,
                                  const PlanOptions& o) {
  const Vec3 axis = n.axis_mcs.normalized();
  const Vec3 u = Across(axis, Vec3::UnitX()), v = axis.cross(u);
  const double r = n.diameter_mm / 2;
  // Aim 0.4 of the way down the wall; the patch reaches up and down from there but stays off
  // the rim and the bottom.
  const double aim_depth = 0.4 * n.depth_mm;
  const double half_depth = std::max(0.1, std::min(o.patch_mm / 2, aim_depth - n.edge_margin_mm));
  const double half_turn = std::min(o.patch_mm / 2 / r, M_PI / o.views_per_circle);
  std::vector<ViewTarget> views;
  for (int k = 0; k < o.views_per_circle; ++k) {
    const double phi = 2 * M_PI * k / o.views_per_circle;
    const Vec3 w = std::cos(phi) * u + std::sin(phi) * v;
    const Vec3 at = n.top_centre_mcs + r * w - aim_depth * axis;
    ViewTarget t = WallView(id + "_" + std::to_string(360 * k / o.views_per_circle), at,
                            n.boss ? w : Vec3(-w), axis, half_depth, o);
    // The patch on the cylinder rather than its tangent plane.
    for (int i = 0; i < t.patch_mcs.cols(); ++i) {
      const int along_turn = i / kPatchSteps, along_depth = i % kPatchSteps;  // patch grid cell
      const double a = phi + half_turn * (-1 + 2.0 * along_turn / (kPatchSteps - 1));
      const double d = aim_depth + half_depth * (-1 + 2.0 * along_depth / (kPatchSteps - 1));
      t.patch_mcs.col(i) = n.top_centre_mcs + r * (std::cos(a) * u + std::sin(a) * v) - d * axis;
    }
    views.push_back(t);
  }
  return views;
}

std::vector<ViewTarget> WidthViews(const WidthNominal& n, const PlanOptions& o) {
  const Vec3 d = n.direction_mcs.normalized();
  const Vec3 up = Across(d, Vec3::UnitZ());
  const double sigma = n.inside ? -1.0 : 1.0;  // the +face's normal into the air is sigma * d
  std::vector<ViewTarget> views;
  for (double side : {1.0, -1.0})
    views.push_back(WallView(side > 0 ? "face_plus" : "face_minus",
                             n.centre_mcs + side * n.width_mm / 2 * d, side * sigma * d, up,
                             std::min(o.patch_mm / 2, n.within_mm), o));
  return views;
}

std::vector<ViewTarget> RectangleViews(const RectangleNominal& n, const PlanOptions& o) {
  const Vec3 axis = n.axis_mcs.normalized();
  const Vec3 x = Across(axis, n.x_direction_mcs), y = axis.cross(x);
  const double sigma = n.inside ? -1.0 : 1.0;
  const double half = std::min(o.patch_mm / 2, n.within_mm);
  std::vector<ViewTarget> views;
  const struct {
    const char* id;
    Vec3 dir;
    double size;
  } faces[] = {{"x_plus", x, n.size_x_mm},
               {"x_minus", -x, n.size_x_mm},
               {"y_plus", y, n.size_y_mm},
               {"y_minus", -y, n.size_y_mm}};
  for (const auto& f : faces)
    views.push_back(
        WallView(f.id, n.centre_mcs + f.size / 2 * f.dir, sigma * f.dir, axis, half, o));
  return views;
}

std::vector<ViewTarget> EllipseViews(const EllipseNominal& n, const PlanOptions& o) {
  const Vec3 axis = n.axis_mcs.normalized();
  const Vec3 u = Across(axis, n.major_direction_mcs), v = axis.cross(u);
  const double a = n.major_mm / 2, b = n.minor_mm / 2, aim_depth = 0.4 * n.depth_mm;
  const double half_depth = std::max(0.1, std::min(o.patch_mm / 2, aim_depth - n.edge_margin_mm));
  std::vector<ViewTarget> views;
  for (int k = 0; k < o.views_per_circle; ++k) {
    const double phi = 2 * M_PI * k / o.views_per_circle;
    const Vec3 at =
        n.top_centre_mcs + a * std::cos(phi) * u + b * std::sin(phi) * v - aim_depth * axis;
    const Vec3 outward = (std::cos(phi) / a * u + std::sin(phi) / b * v).normalized();
    views.push_back(WallView("wall_" + std::to_string(360 * k / o.views_per_circle), at,
                             n.inside ? Vec3(-outward) : outward, axis, half_depth, o));
  }
  return views;
}

std::vector<ViewTarget> SurfaceViews(const SurfaceNominal& n, const PlanOptions& o) {
  if (n.points_mcs.cols() == 0) throw FeatureError("plan: the surface nominal has no points");
  const Vec3 centroid = n.points_mcs.rowwise().mean();
  const Vec3 normal = n.normals_mcs.rowwise().sum().normalized();
  Eigen::Index nearest = 0;
  (n.points_mcs.colwise() - centroid).colwise().squaredNorm().minCoeff(&nearest);
  // At most 200 of the nominal points, spread over the patch, bound the region of interest.
  const Eigen::Index step = std::max<Eigen::Index>(1, n.points_mcs.cols() / 200);
  ViewTarget t;
  t.id = "patch";
  t.mcs_from_camera = CameraAt(n.points_mcs.col(nearest), -normal, Vec3::UnitX(), o.standoff_mm);
  t.patch_mcs.resize(3, (n.points_mcs.cols() + step - 1) / step);
  for (Eigen::Index i = 0, k = 0; i < n.points_mcs.cols(); i += step, ++k)
    t.patch_mcs.col(k) = n.points_mcs.col(i);
  return {t};
}

std::vector<PlannedCapture> PlanCaptures(const std::vector<ViewTarget>& views,
                                         const probe_fw::ProbeModel& probe,
                                         const Pose3& flange_from_probe,
                                         const PlanOptions& o) {
  o.Check();
  const auto& cam = probe.camera;
  std::vector<PlannedCapture> plan;
  for (const ViewTarget& view : views) {
    const Pose3 camera_from_mcs = view.mcs_from_camera.inverse();
    double u0 = 1e300, u1 = -1e300, v0 = 1e300, v1 = -1e300, c0 = 1e300, c1 = -1e300;
    for (Eigen::Index i = 0; i < view.patch_mcs.cols(); ++i) {
      const Vec3 p = camera_from_mcs * Vec3(view.patch_mcs.col(i));
      if (p.z() < 1.0) continue;
      const geometry::Vec2 px = cam.Project(p);
      if (px.x() < 0 || px.y() < 0 || px.x() > cam.width_px - 1 || px.y() > cam.height_px - 1)
        continue;
      u0 = std::min(u0, px.x()), u1 = std::max(u1, px.x());
      v0 = std::min(v0, px.y()), v1 = std::max(v1, px.y());
      const double c = probe.projector.ColumnOf(p);
      c0 = std::min(c0, c), c1 = std::max(c1, c);
    }
    if (u0 > u1)
      throw FeatureError("plan: view " + view.id +
                         " sees none of its patch (nominal, standoff or probe model wrong?)");
    PlannedCapture c;
    c.id = view.id;
    c.mcs_from_flange = view.mcs_from_camera * flange_from_probe.inverse();
    const auto clampi = [](double v, int hi) { return std::clamp(static_cast<int>(v), 0, hi); };
    c.aoi.x0 = clampi(std::floor(u0 - o.aoi_margin_px), cam.width_px - 1);
    c.aoi.y0 = clampi(std::floor(v0 - o.aoi_margin_px), cam.height_px - 1);
    c.aoi.width = clampi(std::ceil(u1 + o.aoi_margin_px), cam.width_px - 1) - c.aoi.x0 + 1;
    c.aoi.height = clampi(std::ceil(v1 + o.aoi_margin_px), cam.height_px - 1) - c.aoi.y0 + 1;
    const double last = probe.projector.columns - 1.0;
    c.first_column = std::clamp(std::floor(c0) - o.column_margin, 0.0, last);
    c.last_column = std::clamp(std::ceil(c1) + o.column_margin, c.first_column, last);
    c.column_step = o.column_step;
    if (view.edge_hint_mcs) {
      const geometry::Vec2 hint = cam.Project(camera_from_mcs * *view.edge_hint_mcs);
      char roi[64];
      std::snprintf(roi, sizeof roi, "edge:%.1f,%.1f", hint.x(), hint.y());
      c.roi = roi;
    }
    plan.push_back(c);
  }
  return plan;
}

std::string CheckReachable(const std::vector<PlannedCapture>& plan) {
  for (const PlannedCapture& c : plan) {
    // The spindle untilted points its flange's z down the machine's -Z (H = T Rz Rx(180 deg):
    // LinuxCNC's M101, the virtual scenes); measured from +Z, every plan of a face was said to
    // need a 180 deg tilt.
    const Vec3 z = c.mcs_from_flange.linear().col(2);
    const double tilt_deg = std::atan2(z.head<2>().norm(), -z.z()) * base::kDegPerRad;
    if (tilt_deg > 0.01)
      return "view " + c.id + " needs the spindle tilted " + Num(tilt_deg) +
             " deg: a 3-axis machine only orients it about Z";
  }
  return "";
}

}  // namespace mlp::features
