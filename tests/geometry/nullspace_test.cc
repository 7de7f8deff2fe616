// Every least-squares fit against reference data with a known exact solution (nullspace.h), on
// the hard cases ISO 10360-6 / TraCIM use: partial arcs down to 10 deg, sphere caps down to
// 15 deg, data 1000 mm from the origin, 5 to 1,000,000 points, form deviations of a few percent.

#include "nullspace.h"

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"

#include <limits>
#include <sstream>

#include "seeded_draw.h"
#include <gtest/gtest.h>

namespace mlp::geometry {
namespace {

using test::Frame;
using test::NullSpaceDeviations;
using test::RandomDirection;

constexpr double kPositionTolMm = 1e-4;  // 0.1 um (TraCIM's tightest limit)
constexpr double kAngleTolRad = 1e-7;    // 0.1 urad
constexpr double kDeg = M_PI / 180.0;

// Reference computations (ISO 10360-6, TraCIM): the least-squares solution however poorly the
// set determines the shape (7 points on a 10 deg arc with 3 % form error: a radius sigma
// several times the radius), so the fits' determinacy test (FitOptions::max_relative_std_dev,
// issue 49) is off here. What these tests check, that the solver reaches the minimum, is
// unchanged.
FitOptions Reference() {
  FitOptions o;
  o.max_relative_std_dev = std::numeric_limits<double>::infinity();
  return o;
}

// Sum of squared orthogonal distances of the points to a shape [mm^2].
template <class Shape, class Pts>
double SumSq(const Shape& shape, const Pts& pts) {
  double ss = 0.0;
  for (Eigen::Index i = 0; i < pts.cols(); ++i) {
    const double d = SignedDistance(shape, pts.col(i).eval());
    ss += d * d;
  }
  return ss;
}

// The fit must never end at a worse point than the known stationary point. Returns true when the
// truth is (to rounding) the minimum the fit found, so its parameters must then agree. Narrow
// sectors of cylinders, cones and ellipses with few points can have a lower minimum elsewhere:
// then the truth is not the least-squares solution, which is only allowed where `may_differ`.
template <class Shape, class Pts>
bool TruthIsTheMinimum(const Shape& fit, const Shape& truth, const Pts& pts, bool may_differ) {
  const double ss_fit = SumSq(fit, pts), ss_truth = SumSq(truth, pts);
  // Absolute floor: an RMS difference of 0.1 nm, a thousandth of the parameter tolerance, so
  // that noise-free data need not be iterated to the last bit.
  const double floor_mm2 = static_cast<double>(pts.cols()) * 1e-14;
  EXPECT_LE(ss_fit, ss_truth * (1.0 + 1e-10) + floor_mm2)
      << "fit ended at a worse stationary point";
  const bool same = ss_fit >= ss_truth * (1.0 - 1e-9) - floor_mm2;
  if (!same) {
    EXPECT_TRUE(may_differ) << "SS fit " << ss_fit << " < truth " << ss_truth
                            << " on data declared well-posed";
  }
  return same;
}

// Cylinder, cone and ellipse on sectors <= 15 deg with <= 30 points are ill-posed.
bool MayDiffer(const struct Case& c);

double AngleUpToSign(const Vec3& a, const Vec3& b) {
  return std::asin(std::min(1.0, a.normalized().cross(b.normalized()).norm()));
}

struct Case {
  int n;
  double span_deg;   // angular extent of the sampled arc / cap / sector
  double offset_mm;  // distance of the feature from the origin
  double form;       // max form deviation as a fraction of the feature size
};

bool MayDiffer(const Case& c) { return c.span_deg <= 15.0 && c.n <= 30; }

std::string Name(const Case& c) {
  std::ostringstream os;
  os << "n" << c.n << "_span" << static_cast<int>(c.span_deg) << "_off"
     << static_cast<int>(c.offset_mm) << "_form" << static_cast<int>(c.form * 1000) << "permille";
  return os.str();
}

class NullSpace : public testing::TestWithParam<Case> {
 protected:
  std::mt19937_64 rng_{20261121u + static_cast<uint64_t>(GetParam().n)};
  Vec3 Offset() { return RandomDirection(rng_) * GetParam().offset_mm; }
};

TEST_P(NullSpace, Circle2) {
  const Case c = GetParam();
  const Circle2 truth{Vec2(0.6, -0.8) * c.offset_mm, 37.5};
  Eigen::MatrixXd jac(c.n, 3);
  std::vector<Vec2> normals(c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = 0.3 + c.span_deg * kDeg * i / (c.n - 1);
    normals[i] = Vec2(std::cos(t), std::sin(t));
    jac.row(i) << -normals[i].transpose(), -1.0;
  }
  const auto e = NullSpaceDeviations(jac, c.form * truth.radius, rng_);
  Points2 pts(2, c.n);
  for (int i = 0; i < c.n; ++i) pts.col(i) = truth.center + (truth.radius + e(i)) * normals[i];
  const auto fit = FitCircle2(pts);
  ASSERT_TRUE(TruthIsTheMinimum(fit.shape, truth, pts, false));
  EXPECT_LT((fit.shape.center - truth.center).norm(), kPositionTolMm);
  EXPECT_NEAR(fit.shape.radius, truth.radius, kPositionTolMm);
}

TEST_P(NullSpace, Sphere) {
  const Case c = GetParam();
  const Sphere truth{Offset(), 12.7};
  const Vec3 pole = RandomDirection(rng_);
  Vec3 u, v;
  Frame(pole, &u, &v);
  // Points on a cap of full angle span_deg around `pole` (polar angle <= span/2).
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  Eigen::MatrixXd jac(c.n, 4);
  Points3 normals(3, c.n);
  const double max_polar = std::min(M_PI, 0.5 * c.span_deg * kDeg);
  for (int i = 0; i < c.n; ++i) {
    const double polar = max_polar * std::sqrt(uni(rng_));
    const double az = 2 * M_PI * uni(rng_);
    normals.col(i) =
        std::cos(polar) * pole + std::sin(polar) * (std::cos(az) * u + std::sin(az) * v);
    jac.row(i) << -normals.col(i).transpose(), -1.0;
  }
  const auto e = NullSpaceDeviations(jac, c.form * truth.radius, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) pts.col(i) = truth.center + (truth.radius + e(i)) * normals.col(i);
  const auto fit = FitSphere(pts, Reference());
  ASSERT_TRUE(TruthIsTheMinimum(fit.shape, truth, pts, false));
  EXPECT_LT((fit.shape.center - truth.center).norm(), kPositionTolMm);
  EXPECT_NEAR(fit.shape.radius, truth.radius, kPositionTolMm);
}

TEST_P(NullSpace, Circle3PlaneThenCircle) {
  const Case c = GetParam();
  const Circle3 truth{Offset(), RandomDirection(rng_), 42.0};
  Vec3 u, v;
  Frame(truth.normal, &u, &v);
  Eigen::MatrixXd jac_circle(c.n, 3), jac_plane(c.n, 3);
  std::vector<Vec2> radial(c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = 1.1 + c.span_deg * kDeg * i / (c.n - 1);
    radial[i] = Vec2(std::cos(t), std::sin(t));
    jac_circle.row(i) << -radial[i].transpose(), -1.0;
    jac_plane.row(i) << 1.0, truth.radius * radial[i].transpose();
  }
  const auto e_r = NullSpaceDeviations(jac_circle, c.form * truth.radius, rng_);
  const auto e_h = NullSpaceDeviations(jac_plane, 0.5 * c.form * truth.radius, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) {
    const Vec3 dir = radial[i].x() * u + radial[i].y() * v;
    pts.col(i) = truth.center + (truth.radius + e_r(i)) * dir + e_h(i) * truth.normal;
  }
  // In-plane deviations change the lever arm of the plane residual: rebuild the plane part
  // on the final in-plane positions so both stages stay exact.
  for (int pass = 0; pass < 1; ++pass) {
    for (int i = 0; i < c.n; ++i) {
      const Vec3 q = pts.col(i) - truth.center;
      jac_plane.row(i) << 1.0, q.dot(u), q.dot(v);
    }
    const auto e2 = NullSpaceDeviations(jac_plane, 0.5 * c.form * truth.radius, rng_);
    for (int i = 0; i < c.n; ++i) {
      const Vec3 q = pts.col(i) - truth.center;
      pts.col(i) = truth.center + q - q.dot(truth.normal) * truth.normal + e2(i) * truth.normal;
    }
  }
  // These data are stationary for the plane-then-circle definition (circle3_test.cc builds
  // them for the spatial one).
  FitOptions plane_first = Reference();
  plane_first.circle3 = Circle3Definition::kPlaneThenCircle;
  const auto fit = FitCircle3(pts, plane_first);
  EXPECT_LT((fit.shape.center - truth.center).norm(), kPositionTolMm);
  EXPECT_LT(AngleUpToSign(fit.shape.normal, truth.normal), kAngleTolRad);
  EXPECT_NEAR(fit.shape.radius, truth.radius, kPositionTolMm);
}

// The ISO 10360-6 circle in space (fit_circle_space.cc): with radial deviations a_i and heights
// h_i over the true circle at angles t_i, the gradient of the sum of squared 3D distances at
// the truth is (-sum a cos t, -sum a sin t, -sum h, R sum h cos t, R sum h sin t, -sum a) in
// (centre u, v, n; tilts; radius). Both a and h orthogonal to (1, cos t, sin t) make it vanish.
TEST_P(NullSpace, Circle3Spatial) {
  const Case c = GetParam();
  const Circle3 truth{Offset(), RandomDirection(rng_), 42.0};
  Vec3 u, v;
  Frame(truth.normal, &u, &v);
  Eigen::MatrixXd jac(c.n, 3);
  std::vector<Vec3> radial(c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = 1.1 + c.span_deg * kDeg * i / (c.n - 1);
    radial[i] = std::cos(t) * u + std::sin(t) * v;
    jac.row(i) << 1.0, std::cos(t), std::sin(t);
  }
  const auto a = NullSpaceDeviations(jac, c.form * truth.radius, rng_);
  const auto h = NullSpaceDeviations(jac, 0.5 * c.form * truth.radius, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i)
    pts.col(i) = truth.center + (truth.radius + a(i)) * radial[i] + h(i) * truth.normal;
  const auto fit = FitCircle3(pts, Reference());  // the spatial definition is the default
  ASSERT_TRUE(TruthIsTheMinimum(fit.shape, truth, pts, false));
  EXPECT_LT((fit.shape.center - truth.center).norm(), kPositionTolMm);
  EXPECT_LT(AngleUpToSign(fit.shape.normal, truth.normal), kAngleTolRad);
  EXPECT_NEAR(fit.shape.radius, truth.radius, kPositionTolMm);
}

TEST_P(NullSpace, Cylinder) {
  const Case c = GetParam();
  if (c.n < 6) GTEST_SUCCEED() << "cylinder needs >= 6 points for redundancy";
  const Cylinder truth{Offset(), RandomDirection(rng_), 20.0};
  Vec3 u, v;
  Frame(truth.axis, &u, &v);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double length = 40.0;
  Eigen::MatrixXd jac(c.n, 5);
  Points3 pts0(3, c.n), normals(3, c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = c.span_deg * kDeg * uni(rng_);
    const double z = length * (uni(rng_) - 0.5);
    normals.col(i) = std::cos(t) * u + std::sin(t) * v;
    pts0.col(i) = truth.point + z * truth.axis + truth.radius * normals.col(i);
    jac.row(i) << -std::cos(t), -std::sin(t), -std::cos(t) * z, -std::sin(t) * z, -1.0;
  }
  const auto e = NullSpaceDeviations(jac, c.form * truth.radius, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) pts.col(i) = pts0.col(i) + e(i) * normals.col(i);
  const auto fit = FitCylinder(pts, Reference());
  if (!TruthIsTheMinimum(fit.shape, truth, pts, MayDiffer(c))) return;
  EXPECT_LT(AngleUpToSign(fit.shape.axis, truth.axis), kAngleTolRad);
  EXPECT_LT((truth.point - fit.shape.point).cross(fit.shape.axis).norm(), kPositionTolMm);
  EXPECT_NEAR(fit.shape.radius, truth.radius, kPositionTolMm);
}

TEST_P(NullSpace, Cone) {
  const Case c = GetParam();
  const Cone truth{Offset(), RandomDirection(rng_), 20.0 * kDeg, 15.0};
  Vec3 u, v;
  Frame(truth.axis, &u, &v);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double cs = std::cos(truth.half_angle), sn = std::sin(truth.half_angle);
  Eigen::MatrixXd jac(c.n, 6);
  Points3 pts0(3, c.n), normals(3, c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = c.span_deg * kDeg * uni(rng_);
    const double z = 30.0 * (uni(rng_) - 0.5);
    const double r = truth.distance / cs + z * std::tan(truth.half_angle);
    const Vec3 radial = std::cos(t) * u + std::sin(t) * v;
    pts0.col(i) = truth.point + z * truth.axis + r * radial;
    normals.col(i) = cs * radial - sn * truth.axis;
    jac.row(i) << -cs * std::cos(t), -cs * std::sin(t),
        -cs * std::cos(t) * z - sn * r * std::cos(t), -cs * std::sin(t) * z - sn * r * std::sin(t),
        -r * sn - z * cs, -1.0;
  }
  const auto e = NullSpaceDeviations(jac, c.form * truth.distance, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) pts.col(i) = pts0.col(i) + e(i) * normals.col(i);
  const auto fit = FitCone(pts, Reference());
  if (!TruthIsTheMinimum(fit.shape, truth, pts, MayDiffer(c))) return;
  EXPECT_LT(std::acos(std::min(1.0, fit.shape.axis.dot(truth.axis))), kAngleTolRad);
  EXPECT_LT((truth.point - fit.shape.point).cross(fit.shape.axis).norm(), kPositionTolMm);
  EXPECT_NEAR(fit.shape.half_angle, truth.half_angle, kAngleTolRad);
  const double t = (truth.point - fit.shape.point).dot(fit.shape.axis);
  EXPECT_NEAR(fit.shape.distance + t * std::sin(fit.shape.half_angle), truth.distance,
              kPositionTolMm);
}

TEST_P(NullSpace, Ellipse3) {
  const Case c = GetParam();
  const double a = 30.0, b = 18.0, angle = 0.7;
  const Vec3 center = Offset(), normal = RandomDirection(rng_);
  Vec3 u, v;
  Frame(normal, &u, &v);
  const Eigen::Rotation2Dd rot(angle);
  Eigen::MatrixXd jac(c.n, 5), jac_plane(c.n, 3);
  Points2 foot(2, c.n), nrm(2, c.n);
  for (int i = 0; i < c.n; ++i) {
    const double t = 0.2 + c.span_deg * kDeg * i / (c.n - 1);
    const Vec2 f(a * std::cos(t), b * std::sin(t));
    const Vec2 nl = Vec2(f.x() / (a * a), f.y() / (b * b)).normalized();
    foot.col(i) = rot * f;
    nrm.col(i) = rot * nl;
    jac.row(i) << -nrm.col(i).transpose(), -nl.x() * std::cos(t), -nl.y() * std::sin(t),
        nl.x() * f.y() - nl.y() * f.x();
  }
  const auto e = NullSpaceDeviations(jac, c.form * b, rng_);
  const Points2 in_plane = foot + nrm * e.asDiagonal();
  for (int i = 0; i < c.n; ++i) jac_plane.row(i) << 1.0, in_plane.col(i).transpose();
  const auto e_h = NullSpaceDeviations(jac_plane, 0.5 * c.form * b, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) {
    pts.col(i) = center + in_plane(0, i) * u + in_plane(1, i) * v + e_h(i) * normal;
  }
  // An ellipse's five parameters are not determined by a <= 15 deg arc with percent-level form
  // deviation: a lower minimum or none. Then a typed error is as right as a better solution.
  const bool narrow = c.span_deg <= 15.0;
  FitResult<Ellipse3> fit;
  try {
    fit = FitEllipse3(pts, Reference());
  } catch (const GeometryError& error) {
    ASSERT_TRUE(narrow) << error.what();
    EXPECT_TRUE(error.code() == ErrorCode::kNotConverged || error.code() == ErrorCode::kDegenerate);
    return;
  }
  const Ellipse3 truth{center, normal, std::cos(angle) * u + std::sin(angle) * v, a, b};
  if (!TruthIsTheMinimum(fit.shape, truth, pts, narrow)) return;
  EXPECT_LT((fit.shape.center - center).norm(), kPositionTolMm);
  EXPECT_LT(AngleUpToSign(fit.shape.normal, normal), kAngleTolRad);
  const Vec3 major = std::cos(angle) * u + std::sin(angle) * v;
  EXPECT_LT(AngleUpToSign(fit.shape.major_axis, major), kAngleTolRad);
  EXPECT_NEAR(fit.shape.semi_major, a, kPositionTolMm);
  EXPECT_NEAR(fit.shape.semi_minor, b, kPositionTolMm);
}

TEST_P(NullSpace, PlaneAndLine) {
  const Case c = GetParam();
  const Vec3 origin = Offset(), normal = RandomDirection(rng_);
  Vec3 u, v;
  Frame(normal, &u, &v);
  std::uniform_real_distribution<double> uni(-25.0, 25.0);
  Eigen::MatrixXd jac(c.n, 3), jac_line(c.n, 2);
  Points2 xy(2, c.n);
  for (int i = 0; i < c.n; ++i) {
    xy.col(i) = test::DrawVec2(uni, rng_).cwiseProduct(Vec2(1.0, 0.4));
    jac.row(i) << 1.0, xy.col(i).transpose();
    jac_line.row(i) << 1.0, xy(0, i);
  }
  const auto e = NullSpaceDeviations(jac, c.form * 25.0, rng_);
  Points3 pts(3, c.n);
  for (int i = 0; i < c.n; ++i) pts.col(i) = origin + xy(0, i) * u + xy(1, i) * v + e(i) * normal;
  const auto plane = FitPlane(pts);
  EXPECT_LT(AngleUpToSign(plane.shape.normal, normal), kAngleTolRad);
  EXPECT_LT(std::abs(SignedDistance(plane.shape, origin)), kPositionTolMm);
  // A 3D line along u with deviations across it in both v and normal directions.
  const auto ev = NullSpaceDeviations(jac_line, c.form * 25.0, rng_);
  const auto en = NullSpaceDeviations(jac_line, c.form * 25.0, rng_);
  for (int i = 0; i < c.n; ++i) pts.col(i) = origin + xy(0, i) * u + ev(i) * v + en(i) * normal;
  const auto line = FitLine3(pts);
  EXPECT_LT(AngleUpToSign(line.shape.direction, u), kAngleTolRad);
  EXPECT_LT(SignedDistance(line.shape, origin), kPositionTolMm);
}

// Sizes of ISO 10360-6 style test sets: few and many points, partial and full features, near
// and far from the origin, form deviations from 0 to 3 % of the size.
INSTANTIATE_TEST_SUITE_P(Hard,
                         NullSpace,
                         testing::Values(Case{7, 10.0, 1000.0, 0.01},
                                         Case{7, 15.0, 0.0, 0.03},
                                         Case{30, 10.0, 1000.0, 0.03},
                                         Case{50, 15.0, 1000.0, 0.02},
                                         Case{100, 90.0, 1000.0, 0.03},
                                         Case{400, 180.0, 500.0, 0.03},
                                         Case{1000, 360.0, 1000.0, 0.03},
                                         Case{1000, 360.0, 1000.0, 0.0},
                                         Case{20000, 120.0, 1000.0, 0.02},
                                         Case{1000000, 200.0, 1000.0, 0.03}),
                         [](const auto& test_info) { return Name(test_info.param); });

}  // namespace
}  // namespace mlp::geometry
