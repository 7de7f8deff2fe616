#include "algebraic.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace mlp::geometry::internal {
namespace {

// Sums of the normal equations of Kasa's fit: rows (p, 1), right-hand side -|p|^2. Written as
// named scalars in one `omp simd` loop (vectorised: this start costs about as much as a
// Gauss-Newton pass otherwise).
// load(i, x, y, z) gives the coordinates of point i (z = 0 for a circle).
template <int N, class Load>
void KasaSums(Eigen::Index n,
              Load load,
              Eigen::Matrix<double, N + 1, N + 1>* ata,
              Eigen::Matrix<double, N + 1, 1>* atb) {
  double sx = 0, sy = 0, sz = 0, xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  double ss = 0, ssx = 0, ssy = 0, ssz = 0;
#pragma omp simd reduction(+ : sx, sy, sz, xx, xy, xz, yy, yz, zz, ss, ssx, ssy, ssz)
  for (Eigen::Index i = 0; i < n; ++i) {
    double x, y, z;
    load(i, x, y, z);
    const double q = x * x + y * y + z * z;
    sx += x, sy += y, sz += z;
    xx += x * x, xy += x * y, xz += x * z, yy += y * y, yz += y * z, zz += z * z;
    ss += q, ssx += q * x, ssy += q * y, ssz += q * z;
  }
  const double dn = static_cast<double>(n);
  if constexpr (N == 2) {
    *ata << xx, xy, sx, xy, yy, sy, sx, sy, dn;
    *atb << -ssx, -ssy, -ss;
  } else {
    *ata << xx, xy, xz, sx, xy, yy, yz, sy, xz, yz, zz, sz, sx, sy, sz, dn;
    *atb << -ssx, -ssy, -ssz, -ss;
  }
}

template <int N, class Load>
bool Kasa(Eigen::Index n, Load load, Eigen::Matrix<double, N, 1>* center, double* radius) {
  Eigen::Matrix<double, N + 1, N + 1> ata;
  Eigen::Matrix<double, N + 1, 1> atb;
  KasaSums<N>(n, load, &ata, &atb);
  const Eigen::Matrix<double, N + 1, 1> sol = ata.ldlt().solve(atb);
  *center = -0.5 * sol.template head<N>();
  const double r2 = center->squaredNorm() - sol(N);
  if (!sol.allFinite() || !(r2 > 0.0)) return false;
  *radius = std::sqrt(r2);
  return true;
}

}  // namespace

bool KasaCircle(const Points2& points, const Vec2& origin, Vec2* center, double* radius) {
  const double* p = points.data();
  const double ox = origin(0), oy = origin(1);
  return Kasa<2>(
      points.cols(),
      [=](Eigen::Index i, double& x, double& y, double& z) {
        x = p[2 * i] - ox, y = p[2 * i + 1] - oy, z = 0.0;
      },
      center, radius);
}

bool KasaCircleInPlane(const Points3& points,
                       const Eigen::Matrix<double, 2, 3>& basis,
                       const Vec3& origin,
                       Vec2* center,
                       double* radius) {
  const double* p = points.data();
  const double ox = origin(0), oy = origin(1), oz = origin(2);
  const double u0 = basis(0, 0), u1 = basis(0, 1), u2 = basis(0, 2);
  const double v0 = basis(1, 0), v1 = basis(1, 1), v2 = basis(1, 2);
  return Kasa<2>(
      points.cols(),
      [=](Eigen::Index i, double& x, double& y, double& z) {
        const double a = p[3 * i] - ox, b = p[3 * i + 1] - oy, c = p[3 * i + 2] - oz;
        x = u0 * a + u1 * b + u2 * c, y = v0 * a + v1 * b + v2 * c, z = 0.0;
      },
      center, radius);
}

bool KasaSphere(const Points3& points, const Vec3& origin, Vec3* center, double* radius) {
  const double* p = points.data();
  const double ox = origin(0), oy = origin(1), oz = origin(2);
  return Kasa<3>(
      points.cols(),
      [=](Eigen::Index i, double& x, double& y, double& z) {
        x = p[3 * i] - ox, y = p[3 * i + 1] - oy, z = p[3 * i + 2] - oz;
      },
      center, radius);
}

Mat3 AlgebraicQuadric(const Points3& centred) {
  // Scale to unit RMS so the ten columns have comparable magnitude.
  const double scale = std::sqrt(centred.squaredNorm() /
                                 static_cast<double>(std::max<Eigen::Index>(1, centred.cols())));
  const double inv = scale > 0.0 ? 1.0 / scale : 1.0;
  Eigen::Matrix<double, 10, 10> dtd = Eigen::Matrix<double, 10, 10>::Zero();
  Eigen::Matrix<double, 10, 1> row;
  for (Eigen::Index i = 0; i < centred.cols(); ++i) {
    const Vec3 p = centred.col(i) * inv;
    row << p.x() * p.x(), p.y() * p.y(), p.z() * p.z(), p.x() * p.y(), p.x() * p.z(), p.y() * p.z(),
        p.x(), p.y(), p.z(), 1.0;
    dtd.noalias() += row * row.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 10, 10>> es(dtd);
  const Eigen::Matrix<double, 10, 1> c = es.eigenvectors().col(0);
  Mat3 a;
  a << c(0), c(3) / 2, c(4) / 2, c(3) / 2, c(1), c(5) / 2, c(4) / 2, c(5) / 2, c(2);
  return a;
}

}  // namespace mlp::geometry::internal
