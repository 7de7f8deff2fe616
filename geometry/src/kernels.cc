#include "kernels.h"

#include <algorithm>

namespace mlp::geometry::internal {
namespace {

// Four lanes of independent partial sums in GCC vector-extension types: one AVX register in
// the AVX2 clone, two SSE2 registers in the baseline one. Plain lane arrays were left scalar by
// GCC 12 for small P, and `omp simd` cannot reduce an array. No sum is reassociated within a
// lane, so the result does not depend on what the compiler does.
typedef double Lanes __attribute__((vector_size(32)));
constexpr int kLanes = 4;

template <int P>
[[gnu::always_inline]] inline void AccumulateRowsImpl(const RowChunk<P>& c,
                                                      int count,
                                                      RowSums<P>* out) {
  Lanes jtj[P][P] = {}, jtr[P] = {}, ss = {};
  Lanes lo = {out->min_r, out->min_r, out->min_r, out->min_r};
  Lanes hi = {out->max_r, out->max_r, out->max_r, out->max_r};
  const int full = count - count % kLanes;
  for (int i = 0; i < full; i += kLanes) {
    Lanes j[P], r;  // loaded by memcpy: no function returns a vector type (that is an ABI matter)
#pragma GCC unroll 8
    for (int a = 0; a < P; ++a) __builtin_memcpy(&j[a], &c.j[a][i], sizeof(Lanes));
    __builtin_memcpy(&r, &c.r[i], sizeof(Lanes));
#pragma GCC unroll 8
    for (int a = 0; a < P; ++a) {
#pragma GCC unroll 8
      for (int b = 0; b <= a; ++b) jtj[a][b] += j[a] * j[b];
      jtr[a] += j[a] * r;
    }
    ss += r * r;
    lo = r < lo ? r : lo;
    hi = r > hi ? r : hi;
  }
  for (int a = 0; a < P; ++a) {
    for (int l = 0; l < kLanes; ++l) {
      for (int b = 0; b <= a; ++b) out->jtj[a][b] += jtj[a][b][l];
      out->jtr[a] += jtr[a][l];
    }
  }
  for (int l = 0; l < kLanes; ++l) {
    out->ss += ss[l];
    out->min_r = std::min(out->min_r, lo[l]);
    out->max_r = std::max(out->max_r, hi[l]);
  }
  for (int i = full; i < count; ++i) {  // the last count % 4 rows
    const double r = c.r[i];
    for (int a = 0; a < P; ++a) {
      for (int b = 0; b <= a; ++b) out->jtj[a][b] += c.j[a][i] * c.j[b][i];
      out->jtr[a] += c.j[a][i] * r;
    }
    out->ss += r * r;
    out->min_r = std::min(out->min_r, r);
    out->max_r = std::max(out->max_r, r);
  }
}

struct BlockResult {
  PointSums3 sums;
  BlockBounds bounds;
  TrialSums trial;
};

// Sums of one block of points; also the trial residual extremes and largest |q|^2 when
// `trial_normal` is given. `omp simd` lets the compiler split these sums across lanes.
[[gnu::always_inline]] inline BlockResult SumBlock(const double* xyz,
                                                   std::int64_t n,
                                                   const double shift[3],
                                                   const double* trial_normal) {
  double sx = 0, sy = 0, sz = 0, xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  const double ax = shift[0], ay = shift[1], az = shift[2];
  if (trial_normal == nullptr) {
#pragma omp simd reduction(+ : sx, sy, sz, xx, xy, xz, yy, yz, zz)
    for (std::int64_t i = 0; i < n; ++i) {
      const double x = xyz[3 * i] - ax, y = xyz[3 * i + 1] - ay, z = xyz[3 * i + 2] - az;
      sx += x, sy += y, sz += z;
      xx += x * x, xy += x * y, xz += x * z, yy += y * y, yz += y * z, zz += z * z;
    }
    return {{{sx, sy, sz}, {xx, xy, xz, yy, yz, zz}}, {0.0, 0.0, 0.0}, {}};
  }
  const double nx = trial_normal[0], ny = trial_normal[1], nz = trial_normal[2];
  double lo = __builtin_inf(), hi = -__builtin_inf(), q2 = 0.0;
  double r1 = 0, r2 = 0, rx = 0, ry = 0, rz = 0;
#pragma omp simd reduction(+ : sx, sy, sz, xx, xy, xz, yy, yz, zz, r1, r2, rx, ry, rz) \
    reduction(min : lo) reduction(max : hi, q2)
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = xyz[3 * i] - ax, y = xyz[3 * i + 1] - ay, z = xyz[3 * i + 2] - az;
    sx += x, sy += y, sz += z;
    xx += x * x, xy += x * y, xz += x * z, yy += y * y, yz += y * z, zz += z * z;
    const double r0 = nx * x + ny * y + nz * z;
    lo = std::min(lo, r0), hi = std::max(hi, r0);
    q2 = std::max(q2, x * x + y * y + z * z);
    r1 += r0, r2 += r0 * r0, rx += r0 * x, ry += r0 * y, rz += r0 * z;
  }
  return {{{sx, sy, sz}, {xx, xy, xz, yy, yz, zz}}, {lo, hi, q2}, {r1, r2, {rx, ry, rz}}};
}

void AddSums(const PointSums3& block, PointSums3* total) {
  for (int k = 0; k < 3; ++k) total->sum[k] += block.sum[k];
  for (int k = 0; k < 6; ++k) total->outer[k] += block.outer[k];
}

}  // namespace

MLP_DISPATCH void AccumulateRows(const RowChunk<3>& c, int count, RowSums<3>* out) {
  AccumulateRowsImpl<3>(c, count, out);
}
MLP_DISPATCH void AccumulateRows(const RowChunk<4>& c, int count, RowSums<4>* out) {
  AccumulateRowsImpl<4>(c, count, out);
}
MLP_DISPATCH void AccumulateRows(const RowChunk<5>& c, int count, RowSums<5>* out) {
  AccumulateRowsImpl<5>(c, count, out);
}
MLP_DISPATCH void AccumulateRows(const RowChunk<6>& c, int count, RowSums<6>* out) {
  AccumulateRowsImpl<6>(c, count, out);
}

// Blocks of 4096 points (96 KB) keep every partial sum small relative to the total, which
// limits the rounding of the long sums (pairwise-like summation), at no cost in speed.
constexpr std::int64_t kSumBlock = 4096;

MLP_DISPATCH PointSums3 SumShiftedPoints(const double* xyz, std::int64_t n, const double shift[3]) {
  PointSums3 total;
  for (std::int64_t start = 0; start < n; start += kSumBlock) {
    const std::int64_t m = std::min(kSumBlock, n - start);
    AddSums(SumBlock(xyz + 3 * start, m, shift, nullptr).sums, &total);
  }
  return total;
}

MLP_DISPATCH PlaneSums SumShiftedPointsWithBounds(const double* xyz,
                                                  std::int64_t n,
                                                  const double shift[3],
                                                  const double trial_normal[3],
                                                  std::int64_t block,
                                                  BlockBounds* bounds) {
  PlaneSums total;
  for (std::int64_t start = 0, k = 0; start < n; start += block, ++k) {
    const std::int64_t m = std::min(block, n - start);
    const BlockResult b = SumBlock(xyz + 3 * start, m, shift, trial_normal);
    AddSums(b.sums, &total.points);
    total.trial.r0 += b.trial.r0, total.trial.r0r0 += b.trial.r0r0;
    for (int a = 0; a < 3; ++a) total.trial.r0q[a] += b.trial.r0q[a];
    bounds[k] = b.bounds;
  }
  return total;
}

}  // namespace mlp::geometry::internal
