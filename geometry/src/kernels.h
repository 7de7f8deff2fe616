#pragma once
// The per-point loops every fit spends its time in, written so that they vectorise across
// points and dispatched at load time to an AVX2+FMA build on CPUs that have it (GCC function
// multiversioning, `target_clones`): the library itself stays baseline x86-64, because the PC
// at a machine tool may be an old Atom. No library offers these kernels: Eigen's GEMM would need
// the Jacobian stored, and it vectorises along the short dimension (P <= 6), not along points.

#include <cstdint>

// An AVX2+FMA clone and a baseline one of a function, chosen once at load time (ifunc), on
// x86-64 with GCC; elsewhere (the probe's ARMv8 board, clang) one portable build: the vector
// types below are GCC/clang vector extensions, NEON on ARM, never x86 intrinsics.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define MLP_DISPATCH __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define MLP_DISPATCH
#endif

namespace mlp::geometry::internal {

// Jacobian rows are gathered in chunks of this many points, stored by parameter (structure of
// arrays), so the accumulation loop runs along points. 128 rows x 7 doubles = 7 KB: stays in L1.
inline constexpr int kChunkRows = 128;

template <int P>
struct RowChunk {
  alignas(64) double j[P][kChunkRows];
  alignas(64) double r[kChunkRows];
};

// Normal-equation sums: lower triangle of J^T J, J^T r, sum r^2 and the residual extremes.
template <int P>
struct RowSums {
  double jtj[P][P] = {};
  double jtr[P] = {};
  double ss = 0.0;
  double min_r = __builtin_inf();
  double max_r = -__builtin_inf();
};

/// Adds the first `count` rows of `chunk` to `sums` (P = 3..6: circle, sphere, cylinder, cone
/// and ellipse).
void AccumulateRows(const RowChunk<3>& chunk, int count, RowSums<3>* sums);
void AccumulateRows(const RowChunk<4>& chunk, int count, RowSums<4>* sums);
void AccumulateRows(const RowChunk<5>& chunk, int count, RowSums<5>* sums);
void AccumulateRows(const RowChunk<6>& chunk, int count, RowSums<6>* sums);

// Raw sums of points shifted by `shift`: sum q, sum q q^T (xx xy xz yy yz zz) with q = p - shift;
// plus, for the one-pass plane fit, per block of `block` points the extremes of the trial
// residual n0 . q and the largest |q|^2 (see FitPlane).
struct PointSums3 {
  double sum[3] = {};
  double outer[6] = {};
};
struct BlockBounds {
  double min_r0, max_r0;  // extremes of n0 . q over the block [mm]
  double max_q2;          // largest |q|^2 over the block [mm^2]
};
/// `xyz`: n points, x y z interleaved (Eigen's 3 x N column-major layout).
PointSums3 SumShiftedPoints(const double* xyz, std::int64_t n, const double shift[3]);
// Sums of the trial residual r0 = n0 . q: sum r0, sum r0^2, sum r0 q.
struct TrialSums {
  double r0 = 0.0, r0r0 = 0.0;
  double r0q[3] = {};
};
struct PlaneSums {
  PointSums3 points;
  TrialSums trial;
};
/// As SumShiftedPoints, plus the trial-residual sums; fills bounds[k] for the points
/// [k block, (k+1) block).
PlaneSums SumShiftedPointsWithBounds(const double* xyz,
                                     std::int64_t n,
                                     const double shift[3],
                                     const double trial_normal[3],
                                     std::int64_t block,
                                     BlockBounds* bounds);

}  // namespace mlp::geometry::internal
