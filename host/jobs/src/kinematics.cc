#include "mlp/jobs/kinematics.h"

#include "mlp/base/format.h"
#include "mlp/geometry/robust.h"

#include <algorithm>
#include <cmath>

namespace mlp::jobs {

SphereSeen SphereOf(const geometry::Points3& points_machine, double radius_mm) {
  const auto robust = geometry::FitSphereRobust(points_machine);
  geometry::Points3 on(3, static_cast<Eigen::Index>(robust.inliers.size()));
  for (size_t k = 0; k < robust.inliers.size(); ++k)
    on.col(static_cast<Eigen::Index>(k)) = points_machine.col(robust.inliers[k]);
  SphereSeen s;
  s.free_radius_mm = robust.fit.shape.radius;
  s.centre_machine_mm = geometry::SphereCentreWithRadius(on, radius_mm, robust.fit.shape.center);
  double sum = 0;
  for (Eigen::Index k = 0; k < on.cols(); ++k) {
    const double r = (on.col(k) - s.centre_machine_mm).norm() - radius_mm;
    sum += r * r;
  }
  s.points = static_cast<int>(on.cols());
  s.left_out = static_cast<int>(points_machine.cols() - on.cols());
  s.rms_mm = on.cols() > 0 ? std::sqrt(sum / static_cast<double>(on.cols())) : 0.0;
  return s;
}

KinematicsOutcome AssessKinematics(const KinematicsInputs& in) {
  KinematicsOutcome o;
  std::vector<calib::TrunnionObservation> centres;
  for (const KinematicsCapture& c : in.captures) {
    if (c.points_machine.cols() < in.min_points) {
      o.problems.push_back("capture " + c.id + " holds " + std::to_string(c.points_machine.cols()) +
                           " points (at least " + std::to_string(in.min_points) + ")");
      continue;
    }
    SphereSeen s;
    try {
      s = SphereOf(c.points_machine, in.sphere_radius_mm);
    } catch (const std::exception& e) {
      o.problems.push_back("capture " + c.id + ": no sphere in its points (" + e.what() + ")");
      continue;
    }
    s.id = c.id, s.a_deg = c.a_deg, s.c_deg = c.c_deg;
    if (s.points < in.min_points || !s.centre_machine_mm.allFinite() ||
        std::abs(s.free_radius_mm - in.sphere_radius_mm) > in.max_radius_error_mm)
      o.problems.push_back("capture " + c.id + ": a sphere of radius " +
                           base::Fixed(s.free_radius_mm, 4) + " mm from " +
                           std::to_string(s.points) + " points, not the reference's " +
                           base::Fixed(in.sphere_radius_mm, 4) + " mm (limit " +
                           base::Fixed(in.max_radius_error_mm, 3) + " mm): not the sphere");
    centres.push_back({s.a_deg, s.c_deg, s.centre_machine_mm});
    o.spheres.push_back(std::move(s));
  }
  if (!o.problems.empty()) return o;
  try {
    o.fit = calib::FitTrunnion(centres, calib::AxesOf(in.pins));
  } catch (const calib::TrunnionError& e) {
    o.problems.push_back(e.what());
    return o;
  }
  o.within = calib::TrunnionWithin(*o.fit, in.pins, in.limits);
  if (in.calibrate) {
    calib::PinCalibration c =
        calib::CalibratePins(*o.fit, in.pins, in.null_band_mm, in.max_change_mm);
    o.changes = std::move(c.changes);
    if (c.problems.empty()) o.new_pins = c.pins;
    o.problems.insert(o.problems.end(), c.problems.begin(), c.problems.end());
  }
  return o;
}

}  // namespace mlp::jobs
