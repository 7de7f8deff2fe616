#pragma once
// A fit against the truth it was drawn from, parameter by parameter in the fit's own reported
// parameters (fit_result.h, Covariance): each error beside the standard deviation the fit
// reported for it. What the sweep (within k sigma) and the repeat test (the reported sigma
// against the scatter) both read.

#include "mlp/geometry/fit.h"

#include <string>
#include <vector>

#include "partial_features.h"

namespace mlp::test::partial {

struct ParameterCheck {
  std::string name;
  double error = 0.0;  ///< fit - truth, in the parameter's unit (mm or rad)
  double sigma = 0.0;  ///< the fit's reported standard deviation
};

// The truth's axis or normal with the fit's sign (a fit may report either sense).
inline Vec3 Aligned(const Vec3& truth, const Vec3& fitted) {
  return truth.dot(fitted) < 0.0 ? -truth : truth;
}

// Tilts of the fitted direction from the truth along the covariance's u and v [rad].
inline void AddTilts(const geometry::Covariance& c,
                     const Vec3& fitted,
                     const Vec3& truth,
                     std::vector<ParameterCheck>* out) {
  const Vec3 t = Aligned(truth, fitted);
  out->push_back({"tilt_u", -t.dot(c.u), c.StdDev("tilt_u")});
  out->push_back({"tilt_v", -t.dot(c.v), c.StdDev("tilt_v")});
}

// A fitted axis through `point` against the true axis through `truth_point`: the offset across
// the true axis at the fitted point, along u and v.
inline void AddAxisOffset(const geometry::Covariance& c,
                          const Vec3& point,
                          const Vec3& truth_point,
                          const Vec3& truth_axis,
                          std::vector<ParameterCheck>* out) {
  const Vec3 d = point - truth_point;
  const Vec3 across = d - d.dot(truth_axis) * truth_axis;
  out->push_back({"offset_u", across.dot(c.u), c.StdDev("offset_u")});
  out->push_back({"offset_v", across.dot(c.v), c.StdDev("offset_v")});
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Circle3>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  const geometry::Covariance& c = f.covariance;
  const Vec3 d = f.shape.center - t.center;
  const Vec3 n = f.shape.normal.cross(c.u).dot(c.v) > 0 ? f.shape.normal : -f.shape.normal;
  out.push_back({"radius", f.shape.radius - t.radius, c.StdDev("radius")});
  out.push_back({"center_u", d.dot(c.u), c.StdDev("center_u")});
  out.push_back({"center_v", d.dot(c.v), c.StdDev("center_v")});
  out.push_back({"center_w", d.dot(n), c.StdDev("center_w")});
  AddTilts(c, n, t.axis, &out);
  return out;
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Sphere>& f,
                                          const Truth& t) {
  const geometry::Covariance& c = f.covariance;
  const Vec3 d = f.shape.center - t.center;
  return {{"radius", f.shape.radius - t.radius, c.StdDev("radius")},
          {"center_x", d.x(), c.StdDev("center_x")},
          {"center_y", d.y(), c.StdDev("center_y")},
          {"center_z", d.z(), c.StdDev("center_z")}};
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Cylinder>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  const geometry::Covariance& c = f.covariance;
  const Vec3 a = Aligned(t.axis, f.shape.axis);
  out.push_back({"radius", f.shape.radius - t.radius, c.StdDev("radius")});
  AddAxisOffset(c, f.shape.point, t.center, a, &out);
  AddTilts(c, f.shape.axis, t.axis, &out);
  return out;
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Cone>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  const geometry::Covariance& c = f.covariance;
  // The true cone's radius where the fitted point lies along its axis, and its distance there.
  const double z = (f.shape.point - t.center).dot(t.axis);
  const double radius_there = t.radius + z * std::tan(t.half_angle);
  out.push_back({"half_angle", f.shape.half_angle - t.half_angle, c.StdDev("half_angle")});
  out.push_back(
      {"distance", f.shape.distance - radius_there * std::cos(t.half_angle), c.StdDev("distance")});
  AddAxisOffset(c, f.shape.point, t.center, t.axis, &out);
  AddTilts(c, f.shape.axis, t.axis, &out);
  return out;
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Line3>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  AddAxisOffset(f.covariance, f.shape.point, t.center, t.axis, &out);
  AddTilts(f.covariance, f.shape.direction, t.axis, &out);
  return out;
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Plane>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  const Vec3 n = Aligned(t.axis, f.shape.normal);
  out.push_back({"offset", (f.shape.point - t.center).dot(n), f.covariance.StdDev("offset")});
  AddTilts(f.covariance, f.shape.normal, t.axis, &out);
  return out;
}

inline std::vector<ParameterCheck> Checks(const geometry::FitResult<geometry::Ellipse3>& f,
                                          const Truth& t) {
  std::vector<ParameterCheck> out;
  const geometry::Covariance& c = f.covariance;
  out.push_back({"semi_major", f.shape.semi_major - t.radius, c.StdDev("semi_major")});
  out.push_back({"semi_minor", f.shape.semi_minor - t.minor, c.StdDev("semi_minor")});
  const Vec3 d = f.shape.center - t.center;
  out.push_back({"center_u", d.dot(c.u), c.StdDev("center_u")});
  out.push_back({"center_v", d.dot(c.v), c.StdDev("center_v")});
  AddTilts(c, f.shape.normal, t.axis, &out);
  return out;
}

}  // namespace mlp::test::partial
