#include "mlp/sim/speckle.h"

#include "mlp/base/check.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace mlp::sim {
namespace {

constexpr double kFirstZero = 3.8317059702075125;  // of J1: the Airy radius in v
constexpr double kThirdZero = 10.173468135062722;  // the kernel ends at the third dark ring

// The Airy amplitude 2 J1(v) / v.
double AiryAmplitude(double v) { return v < 1e-8 ? 1.0 : 2.0 * std::cyl_bessel_j(1.0, v) / v; }

}  // namespace

SpeckleImager::SpeckleImager(
    int width_px, int height_px, double airy_radius_px, double contrast, std::uint64_t seed)
    : w_(width_px), h_(height_px), contrast_(contrast) {
  MLP_CHECK_MSG(w_ > 0 && h_ > 0 && airy_radius_px > 0.05 && airy_radius_px < 50.0 &&
                    contrast >= 0.0 && contrast <= 1.0,
                "speckle: Airy radius must be 0.05..50 px, contrast 0..1");
  // The intensity's spectrum ends at 2 / (lambda N) = 2.44 / airy_radius: sample it at least
  // that finely, and at least 3 x 3 per pixel (its mean of |field|^2 is the pixel integral).
  q_ = std::max(3, static_cast<int>(std::ceil(2.0 * 1.22 / airy_radius_px)));
  const double step = 1.0 / q_;
  reach_ = static_cast<int>(std::ceil(airy_radius_px * kThirdZero / kFirstZero / step));
  // The kernel as rows of contiguous taps (dy, dx from -half to +half): the inner loop runs
  // along a row of the field without a bounds test (the field has a margin of reach_).
  double energy = 0.0;
  for (int dy = -reach_; dy <= reach_; ++dy) {
    KernelRow row;
    row.dy = dy;
    for (int dx = -reach_; dx <= reach_; ++dx) {
      const double v = kFirstZero * std::hypot(dx, dy) * step / airy_radius_px;
      if (v > kThirdZero) continue;
      if (row.taps.empty()) row.dx0 = dx;
      row.taps.push_back(Cell::Constant(static_cast<float>(AiryAmplitude(v))));
      energy += AiryAmplitude(v) * AiryAmplitude(v);
    }
    if (!row.taps.empty()) kernel_.push_back(std::move(row));
  }
  // Unit energy: the mean of |field|^2 over the phases is the irradiance blurred by |h|^2.
  for (KernelRow& row : kernel_) {
    for (Cell& tap : row.taps) {
      const auto a = static_cast<float>(tap(0) / std::sqrt(energy));
      tap << a, a, a * a, 0.0f;
    }
  }
  const size_t n = static_cast<size_t>(w_) * q_ * static_cast<size_t>(h_) * q_;
  phase_.resize(n);
  std::mt19937_64 engine(seed);
  for (auto& p : phase_) {
    const double phi = 2.0 * M_PI * static_cast<double>(engine() >> 11) * 0x1.0p-53;
    p = {static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi))};
  }
  irradiance_.assign(n, 0.0f);
  const size_t padded = static_cast<size_t>(w_ * q_ + 2 * reach_) * (h_ * q_ + 2 * reach_);
  field_.assign(padded, Cell::Zero());
  lit_lo_.assign(static_cast<size_t>(h_) * q_, w_ * q_);
  lit_hi_.assign(static_cast<size_t>(h_) * q_, -1);
}

// Adds one scatterer's field (amplitude a, light e) at padded position (x, y) through the kernel.
void SpeckleImager::Scatter(int x, int y, std::complex<float> a, float e) {
  const int Wp = w_ * q_ + 2 * reach_;
  // One 4-float operation per tap (re += amplitude a_re, im += amplitude a_im, light +=
  // amplitude^2 e): the same operations as three float loops, in a quarter of the checks under
  // AddressSanitizer, where the loop over separate arrays was two thirds of an acceptance run.
  const Cell source(a.real(), a.imag(), e, 0.0f);
  for (const KernelRow& row : kernel_) {
    Cell* cell =
        field_.data() + static_cast<size_t>(y + row.dy) * Wp + static_cast<size_t>(x + row.dx0);
    for (const Cell& tap : row.taps) *cell++ += tap * source;
  }
}

void SpeckleImager::Image(std::vector<double>* pixel_e) {
  const int W = w_ * q_, H = h_ * q_, Wp = W + 2 * reach_;
  pixel_e->assign(static_cast<size_t>(w_) * h_, 0.0);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      const float e = irradiance_[i];
      if (e <= 0.0f) continue;
      irradiance_[i] = 0.0f;
      Scatter(x + reach_, y + reach_, std::sqrt(e) * phase_[i], e);
      lit_lo_[y] = std::min(lit_lo_[y], x), lit_hi_[y] = std::max(lit_hi_[y], x);
    }
  }
  // Where light can have landed on sub-row y: the lit stretches of the rows within reach_,
  // widened by reach_ (clipped to the AOI: light beyond its edge is not read out).
  const double per_sub = 1.0 / (q_ * q_);
  for (int y = 0; y < H; ++y) {
    int lo = W, hi = -1;
    for (int yi = std::max(0, y - reach_); yi <= std::min(H - 1, y + reach_); ++yi)
      lo = std::min(lo, lit_lo_[yi] - reach_), hi = std::max(hi, lit_hi_[yi] + reach_);
    lo = std::max(lo, 0), hi = std::min(hi, W - 1);
    for (int x = lo; x <= hi; ++x) {
      const size_t o = static_cast<size_t>(y + reach_) * Wp + static_cast<size_t>(x + reach_);
      const Cell& c = field_[o];
      const double field = double(c(0)) * c(0) + double(c(1)) * c(1);
      const double e = (1.0 - contrast_) * c(2) + contrast_ * field;
      (*pixel_e)[static_cast<size_t>(y / q_) * w_ + x / q_] += e * per_sub;
    }
  }
  // Clear what the scatterers touched, margin included.
  for (int y = 0; y < H; ++y) {
    if (lit_hi_[y] < 0) continue;
    for (int yo = y; yo <= y + 2 * reach_; ++yo) {
      const size_t o = static_cast<size_t>(yo) * Wp + static_cast<size_t>(lit_lo_[y]);
      const size_t n =
          static_cast<size_t>(lit_hi_[y] - lit_lo_[y]) + 2 * static_cast<size_t>(reach_) + 1;
      std::fill_n(field_.begin() + static_cast<std::ptrdiff_t>(o), n, Cell::Zero());
    }
  }
  std::fill(lit_lo_.begin(), lit_lo_.end(), W);
  std::fill(lit_hi_.begin(), lit_hi_.end(), -1);
}

}  // namespace mlp::sim
