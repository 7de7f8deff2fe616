#include "mlp/sim/speckle.h"

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
  if (w_ <= 0 || h_ <= 0 || !(airy_radius_px > 0.05 && airy_radius_px < 50.0) ||
      !(contrast >= 0.0 && contrast <= 1.0)) {
    throw std::invalid_argument("speckle: Airy radius must be 0.05..50 px, contrast 0..1");
  }
  // The field's spectrum ends at 1 / (lambda N) = 1.22 / airy_radius; sample it at least 1.25x
  // finer than Nyquist, and never coarser than a third of a pixel (the pixel's integral).
  q_ = std::max(3, static_cast<int>(std::ceil(1.25 * 2.0 * 1.22 / airy_radius_px)));
  const double step = 1.0 / q_;
  const int reach = static_cast<int>(std::ceil(airy_radius_px * kThirdZero / kFirstZero / step));
  double energy = 0.0;
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      const double v = kFirstZero * std::hypot(dx, dy) * step / airy_radius_px;
      if (v > kThirdZero) continue;
      const double a = AiryAmplitude(v);
      taps_.push_back({dx, dy, static_cast<float>(a)});
      energy += a * a;
    }
  }
  // Unit energy: the mean of |field|^2 over the phases is the irradiance blurred by |h|^2.
  for (Tap& t : taps_) t.amplitude = static_cast<float>(t.amplitude / std::sqrt(energy));
  const size_t n = static_cast<size_t>(w_) * q_ * static_cast<size_t>(h_) * q_;
  phase_.resize(n);
  std::mt19937_64 engine(seed);
  for (auto& p : phase_) {
    const double phi = 2.0 * M_PI * static_cast<double>(engine() >> 11) * 0x1.0p-53;
    p = {static_cast<float>(std::cos(phi)), static_cast<float>(std::sin(phi))};
  }
  irradiance_.assign(n, 0.0f);
  field_.assign(n, {0.0f, 0.0f});
  incoherent_.assign(n, 0.0f);
  row_lo_.assign(static_cast<size_t>(h_) * q_, w_ * q_);
  row_hi_.assign(static_cast<size_t>(h_) * q_, -1);
}

void SpeckleImager::Image(std::vector<double>* pixel_e) {
  const int W = w_ * q_, H = h_ * q_;
  pixel_e->assign(static_cast<size_t>(w_) * h_, 0.0);
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      const float e = irradiance_[i];
      if (e <= 0.0f) continue;
      irradiance_[i] = 0.0f;
      const std::complex<float> a = std::sqrt(e) * phase_[i];
      for (const Tap& t : taps_) {
        const int xo = x + t.dx, yo = y + t.dy;
        if (xo < 0 || yo < 0 || xo >= W || yo >= H) continue;
        const size_t o = static_cast<size_t>(yo) * W + xo;
        field_[o] += t.amplitude * a;
        incoherent_[o] += t.amplitude * t.amplitude * e;
        row_lo_[yo] = std::min(row_lo_[yo], xo), row_hi_[yo] = std::max(row_hi_[yo], xo);
      }
    }
  }
  const double per_sub = 1.0 / (q_ * q_);
  for (int y = 0; y < H; ++y) {
    for (int x = row_lo_[y]; x <= row_hi_[y]; ++x) {
      const size_t o = static_cast<size_t>(y) * W + x;
      const double e = (1.0 - contrast_) * incoherent_[o] + contrast_ * std::norm(field_[o]);
      (*pixel_e)[static_cast<size_t>(y / q_) * w_ + x / q_] += e * per_sub;
      field_[o] = {0.0f, 0.0f}, incoherent_[o] = 0.0f;
    }
    row_lo_[y] = W, row_hi_[y] = -1;
  }
}

}  // namespace mlp::sim
