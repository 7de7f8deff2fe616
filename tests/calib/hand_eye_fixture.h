#pragma once
// Ground truth for the hand-eye tests: a probe mounted on the flange with a small misalignment,
// a reference sphere on the table, and flange poses that put the sphere in front of the probe.

#include "mlp/calib/hand_eye.h"

#include <cmath>
#include <cstdio>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "seeded_draw.h"
#include <gtest/gtest.h>

namespace mlp::calib::testing {

struct Truth {
  Pose3 flange_from_probe = Pose3::Identity();
  Vec3 centre_mcs = Vec3::Zero();
  double radius_mm = 12.7;
};

/// The probe 140 mm below the spindle nose, looking down (camera z = flange -Z), mounted 1.2
/// degrees off in spin and a few tenths off in tilt; the sphere somewhere on the table.
inline Truth DefaultTruth() {
  Truth t;
  t.flange_from_probe.linear() =
      Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix() *
      Eigen::AngleAxisd(0.021, Vec3(0.2, -0.15, 1.0).normalized()).toRotationMatrix();
  t.flange_from_probe.translation() = Vec3(0.83, -0.47, -140.2);
  t.centre_mcs = Vec3(250.0, -120.0, -350.0);
  return t;
}

enum class PoseSet { kTranslationsOnly, kThreeAxisWithM19, kFiveAxis };

inline Eigen::Matrix3d Rot(double angle_rad, const Vec3& axis) {
  return Eigen::AngleAxisd(angle_rad, axis.normalized()).toRotationMatrix();
}

/// Flange poses H_i with the sphere centre at a chosen place in front of the probe (probe frame:
/// x, y within +-6 mm of the optical axis, 117-133 mm away).
inline std::vector<Pose3> MakePoses(const Truth& truth, PoseSet set, int n) {
  std::vector<Pose3> poses;
  for (int i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    const Vec3 q(6.0 * std::sin(1.3 * s), 6.0 * std::cos(2.1 * s), 125.0 + 8.0 * std::sin(0.7 * s));
    Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
    const double spin = M_PI / 2 * (i % 4) + 0.1 * (i / 4);
    if (set == PoseSet::kThreeAxisWithM19) r = Rot(spin, Vec3::UnitZ());
    if (set == PoseSet::kFiveAxis) {
      const double tilt = (i % 3 == 0 ? 0.0 : (i % 3 == 1 ? 0.35 : -0.5));
      r = Rot(spin, Vec3::UnitZ()) * Rot(tilt, i % 2 ? Vec3::UnitX() : Vec3::UnitY());
    }
    Pose3 h = Pose3::Identity();
    h.linear() = r;
    h.translation() = truth.centre_mcs - r * (truth.flange_from_probe * q);
    poses.push_back(h);
  }
  return poses;
}

/// Where the sphere centre is in the probe frame at pose h.
inline Vec3 CentreInProbe(const Truth& truth, const Pose3& h) {
  return (h * truth.flange_from_probe).inverse() * truth.centre_mcs;
}

/// One capture per pose, its points made by `fill(q, &points, gen)` with q the sphere centre in
/// the probe frame.
template <class Fill>
std::vector<SphereCapture> PerPose(const Truth& truth,
                                   const std::vector<Pose3>& poses,
                                   const std::string& prefix,
                                   unsigned seed,
                                   Fill fill) {
  std::mt19937 gen(seed);
  std::vector<SphereCapture> out;
  for (size_t i = 0; i < poses.size(); ++i) {
    SphereCapture c;
    c.id = prefix + std::to_string(i);
    c.mcs_from_flange = poses[i];
    fill(CentreInProbe(truth, poses[i]), &c.points_in_probe, gen);
    out.push_back(std::move(c));
  }
  return out;
}

/// Caps of the sphere as the probe sees them (normals within 60 degrees of the line of sight),
/// Gaussian noise along the normal, and a fraction of background points around the sphere.
inline std::vector<SphereCapture> SyntheticCaps(const Truth& truth,
                                                const std::vector<Pose3>& poses,
                                                double noise_mm,
                                                double outlier_fraction,
                                                int points,
                                                unsigned seed) {
  return PerPose(truth, poses, "cap-", seed, [&](const Vec3& q, geometry::Points3* pts, auto& gen) {
    std::normal_distribution<double> normal(0.0, 1.0);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    pts->resize(3, points);
    for (int k = 0; k < points; ++k) {
      if (unit(gen) * 0.5 + 0.5 < outlier_fraction) {
        pts->col(k) = q + 1.5 * truth.radius_mm * test::DrawVec3(unit, gen);
        continue;
      }
      Vec3 n;
      do {
        n = test::DrawVec3(normal, gen).normalized();
      } while (n.dot(-q.normalized()) < std::cos(M_PI / 3));
      pts->col(k) = q + (truth.radius_mm + noise_mm * normal(gen)) * n;
    }
  });
}

/// One laser profile per pose, in the probe's y = 0 plane as a line scanner's: the visible arc
/// of the circle where the plane cuts the sphere, noise along the normal, and the table behind.
inline std::vector<SphereCapture> SyntheticProfiles(const Truth& truth,
                                                    const std::vector<Pose3>& poses,
                                                    double noise_mm,
                                                    int points,
                                                    unsigned seed) {
  auto out = PerPose(
      truth, poses, "profile-", seed, [&](const Vec3& q, geometry::Points3* pts, auto& gen) {
        std::normal_distribution<double> normal(0.0, 1.0);
        std::uniform_real_distribution<double> unit(-1.0, 1.0);
        const double rho = std::sqrt(truth.radius_mm * truth.radius_mm - q.y() * q.y());
        const int background = points / 2;
        pts->resize(3, points + background);
        for (int k = 0; k < points; ++k) {
          // Arc facing the probe: angles within 70 degrees of the -z direction in the plane.
          const double a = -M_PI / 2 + unit(gen) * 1.2;
          const Vec3 on_circle(q.x() + rho * std::cos(a), 0.0, q.z() + rho * std::sin(a));
          const Vec3 p = on_circle + noise_mm * normal(gen) * (on_circle - q).normalized();
          pts->col(k) = Vec3(p.x(), 0.0, p.z());  // the profile is exactly planar
        }
        for (int k = 0; k < background; ++k) {  // the table, hidden behind the sphere
          double x = q.x() + 40.0 * unit(gen);
          if (std::abs(x - q.x()) < rho + 2) x = q.x() + rho + 5 + 30 * std::abs(unit(gen));
          pts->col(points + k) = Vec3(x, 0.0, q.z() + 30.0 + noise_mm * normal(gen));
        }
      });
  for (auto& c : out) c.single_profile = true;
  return out;
}

/// Rotation angle of a pose [arcsec].
inline double Arcsec(const Pose3& p) {
  return Eigen::AngleAxisd(p.linear()).angle() * 180.0 / M_PI * 3600.0;
}

/// How far a result is from the truth, printed for the record.
struct Errors {
  double translation_mm, rotation_arcsec, centre_mm;
};
inline Errors ErrorsOf(const Truth& truth, const HandEyeResult& r, const char* label) {
  const Errors e{(r.flange_from_probe.translation() - truth.flange_from_probe.translation()).norm(),
                 Arcsec(truth.flange_from_probe.inverse() * r.flange_from_probe),
                 (r.centre_mcs - truth.centre_mcs).norm()};
  std::printf(
      "%s: M error %.3f um, %.2f arcsec; centre error %.3f um; point RMS %.2f um; "
      "%d points rejected\n",
      label, e.translation_mm * 1e3, e.rotation_arcsec, e.centre_mm * 1e3, r.point_rms_mm * 1e3,
      r.points_rejected);
  return e;
}

/// The refusal of a solve that must be refused (a test failure if it is not).
inline std::optional<HandEyeError> Refusal(const std::vector<SphereCapture>& captures,
                                           const HandEyeOptions& o) {
  try {
    SolveSphereHandEye(captures, o);
  } catch (const HandEyeError& e) {
    return e;
  }
  ADD_FAILURE() << "accepted";
  return std::nullopt;
}

}  // namespace mlp::calib::testing
