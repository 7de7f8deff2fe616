#include "mlp/grind/grind_frame.h"

#include "mlp/base/raster.h"
#include "mlp/grey_image/grey_image.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace mlp::grind {
namespace {

using geometry::Vec2;

constexpr int kSub = 8;  // sub-samples a side in pixels on the boundary, jittered (stratified)

struct Swept {
  Vec2 center;
  WheelSection section;
};

// Negative inside the material: the stock region's signed distance and each stroke's section's,
// combined (max: inside the stock and outside every section). Each term is 1-Lipschitz, so |f|
// bounds the distance to the boundary from below: a pixel whose centre is over 0.75 px from it
// is whole.
double Material(const geometry::Profile2& p,
                double stock,
                const std::vector<Swept>& s,
                const Vec2& x) {
  double f = p.Closest(x).signed_distance - stock;
  for (const Swept& w : s) f = std::max(f, -w.section.SignedDistanceMm(x - w.center));
  return f;
}

}  // namespace

void GrindCamera::Validate() const {
  if (width_px < 16 || height_px < 16 || width_px > 8192 || height_px > 8192)
    throw GrindInputError("grind camera: the image must be 16..8192 px each way");
  if (!(mm_per_px > 0) || !(bright > dark) || !(noise_sigma >= 0) || !(psf_sigma_px >= 0))
    throw GrindInputError("grind camera: mm_per_px > 0, bright > dark, noise and blur >= 0");
}

std::vector<std::uint8_t> RenderGrindFrame(const geometry::Profile2& nominal,
                                           double stock_mm,
                                           const std::vector<WheelStroke>& strokes,
                                           const GrindCamera& c,
                                           unsigned seed,
                                           const WheelBevel& bevel) {
  c.Validate();
  std::vector<Swept> swept;
  swept.reserve(strokes.size());
  for (const WheelStroke& w : strokes)
    swept.push_back({w.center_mm, WheelSection(w.radius_mm, bevel)});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0, 1);
  const size_t n = base::RasterSize(c.width_px, c.height_px);
  std::vector<double> cover(n);
  const double whole = 0.75 * c.mm_per_px;
  // Blocks of kBlock x kBlock pixels whose middle is further from the boundary than the
  // block's half diagonal are one state throughout (f is 1-Lipschitz): most of the image.
  constexpr int kBlock = 8;
  const double block_reach = (kBlock / std::sqrt(2.0) + 1) * c.mm_per_px;
  const int blocks_across = c.width_px / kBlock + 1;
  std::vector<signed char> block_state(base::RasterSize(blocks_across, c.height_px / kBlock + 1),
                                       0);
  for (int by = 0; by * kBlock < c.height_px; ++by)
    for (int bx = 0; bx * kBlock < c.width_px; ++bx) {
      const Vec2 mid(bx * kBlock + (kBlock - 1) / 2.0, by * kBlock + (kBlock - 1) / 2.0);
      const double f = Material(nominal, stock_mm, swept, c.ToMm(mid));
      block_state[base::RasterIndex(bx, by, blocks_across)] = f < -block_reach  ? 1
                                                              : f > block_reach ? -1
                                                                                : 0;
    }
  for (int v = 0; v < c.height_px; ++v)
    for (int u = 0; u < c.width_px; ++u) {
      const signed char state =
          block_state[base::RasterIndex(u / kBlock, v / kBlock, blocks_across)];
      const double f =
          state != 0 ? state * -1.0 : Material(nominal, stock_mm, swept, c.ToMm({u, v}));
      double share = f < -whole ? 1.0 : 0.0;
      if (std::abs(f) <= whole) {
        int inside = 0;
        for (int i = 0; i < kSub; ++i)
          for (int j = 0; j < kSub; ++j) {
            // One draw per statement, v's first: the order GCC gave the former one-expression
            // form (C++ leaves it open), so the frames stay as they were on every compiler.
            const double jitter_v = unit(rng);
            const double jitter_u = unit(rng);
            const Vec2 q(u - 0.5 + (i + jitter_u) / kSub, v - 0.5 + (j + jitter_v) / kSub);
            inside += Material(nominal, stock_mm, swept, c.ToMm(q)) < 0;
          }
        share = static_cast<double>(inside) / (kSub * kSub);
      }
      cover[static_cast<size_t>(v) * static_cast<size_t>(c.width_px) + static_cast<size_t>(u)] =
          c.bright - (c.bright - c.dark) * share;
    }
  grey_image::GaussianBlur(&cover, c.width_px, c.height_px, c.psf_sigma_px);
  std::normal_distribution<double> noise(0, c.noise_sigma);
  std::vector<std::uint8_t> px(n);
  for (size_t i = 0; i < n; ++i)
    px[i] = static_cast<std::uint8_t>(
        std::clamp(std::lround(cover[i] + (c.noise_sigma > 0 ? noise(rng) : 0.0)), 0L, 255L));
  return px;
}

}  // namespace mlp::grind
