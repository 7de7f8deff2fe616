#include "algebraic.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace mlp::geometry::internal {
namespace {

template <int N>
bool Kasa(const Eigen::Matrix<double, N, Eigen::Dynamic>& centred,
          Eigen::Matrix<double, N, 1>* center,
          double* radius) {
  Eigen::Matrix<double, N + 1, N + 1> ata = Eigen::Matrix<double, N + 1, N + 1>::Zero();
  Eigen::Matrix<double, N + 1, 1> atb = Eigen::Matrix<double, N + 1, 1>::Zero();
  Eigen::Matrix<double, N + 1, 1> row;
  for (Eigen::Index i = 0; i < centred.cols(); ++i) {
    row << centred.col(i), 1.0;
    ata.noalias() += row * row.transpose();
    atb += row * (-centred.col(i).squaredNorm());
  }
  const Eigen::Matrix<double, N + 1, 1> sol = ata.ldlt().solve(atb);
  *center = -0.5 * sol.template head<N>();
  const double r2 = center->squaredNorm() - sol(N);
  if (!sol.allFinite() || !(r2 > 0.0)) return false;
  *radius = std::sqrt(r2);
  return true;
}

}  // namespace

bool KasaCircle(const Points2& centred, Vec2* center, double* radius) {
  return Kasa<2>(centred, center, radius);
}

bool KasaSphere(const Points3& centred, Vec3* center, double* radius) {
  return Kasa<3>(centred, center, radius);
}

Mat3 AlgebraicQuadric(const Points3& centred) {
  // Scale to unit RMS so the ten columns have comparable magnitude.
  const double scale = std::sqrt(centred.squaredNorm() / std::max<Eigen::Index>(1, centred.cols()));
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
