#include "mlp/sim/render.h"

#include "mlp/probe_fw/agent.h"
#include "mlp/sim/brdf.h"
#include "mlp/sim/speckle.h"

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>

#include "pixel.h"

namespace mlp::sim {

using geometry::Vec2;
using probe_fw::Frame;

namespace {

// Shop light falls on the far background too, which reflects little of it back.
constexpr double kBackgroundFactor = 0.02;

// Standard normal deviates by Box-Muller on mt19937_64: std::normal_distribution's algorithm is
// not fixed by the standard, and frames must be identical for a seed on every platform.
class Gaussian {
 public:
  explicit Gaussian(std::uint64_t seed) : engine_(seed) {}
  double operator()() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    constexpr double kScale = 1.0 / 9007199254740992.0;  // 2^-53
    const double u1 = (static_cast<double>(engine_() >> 11) + 0.5) * kScale;
    const double u2 = static_cast<double>(engine_() >> 11) * kScale;
    const double r = std::sqrt(-2.0 * std::log(u1));
    spare_ = r * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return r * std::cos(2.0 * M_PI * u2);
  }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

// SplitMix64 (Steele et al. 2014): independent seeds per frame from one user seed.
std::uint64_t FrameSeed(std::uint64_t seed, std::uint64_t frame) {
  std::uint64_t z = seed + 0x9e3779b97f4a7c15ULL * (frame + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// Mean of exp(-2 (a + b s)^2 / w^2) over s in [-1/2, 1/2]: the laser sheet's Gaussian integrated
// across the pixel, a = column offset at the pixel centre, b = how far the column changes across
// the pixel.
double PixelAveragedSheet(double a, double b, double w) {
  if (std::abs(a) > 4.0 * w + std::abs(b)) return 0.0;
  if (std::abs(b) < 1e-6 * w) return std::exp(-2.0 * a * a / (w * w));
  const double k = std::sqrt(2.0) / w;
  return (std::sqrt(M_PI / 8.0) * w / b) *
         (std::erf(k * (a + 0.5 * b)) - std::erf(k * (a - 0.5 * b)));
}

// The speckle's own random stream: the surface's phases, one per capture, apart from the frames'.
constexpr std::uint64_t kSurfacePhaseStream = 1ULL << 40;

// Grain from the aperture when the model gives one (speckle.h); else independent per pixel.
bool CoherentSpeckle(const probe_fw::ProbeModel& m) {
  return m.camera.f_number > 0.0 && m.noise.speckle_contrast > 0.0 && m.laser.wavelength_nm > 0.0;
}

// The Airy radius on the sensor, 1.22 lambda N / pitch [px]: the pinhole's image distance
// fx pitch as the lens's, so the grain seen from the surface is that of the aperture
// sin u = D / 2z (CameraModel::ApertureSinAt).
double AiryRadiusPx(const probe_fw::ProbeModel& m) {
  return 1.22 * m.laser.wavelength_nm * 1e-6 * m.camera.f_number / m.camera.pixel_pitch_mm;
}

void CheckSweep(const probe_fw::ProbeModel& model, const SweepOptions& o) {
  const auto& c = model.camera;
  if (o.aoi.width <= 0 || o.aoi.height <= 0 || o.aoi.x0 < 0 || o.aoi.y0 < 0 ||
      o.aoi.x0 + o.aoi.width > c.width_px || o.aoi.y0 + o.aoi.height > c.height_px) {
    throw probe_fw::RequestError("sweep: the AOI must lie inside the sensor");
  }
  if (!(o.exposure > 0.0 && o.exposure <= 1e4))
    throw probe_fw::RequestError("sweep: exposure must be in (0, 1e4] times the model's");
  if (!(o.column_step > 0.0) || !(o.last_column >= o.first_column) || o.first_column < 0.0 ||
      o.last_column > model.projector.columns - 1) {
    throw probe_fw::RequestError(
        "sweep: columns must satisfy 0 <= first <= last < columns, step > 0");
  }
}

}  // namespace

VirtualProbe::VirtualProbe(probe_fw::ProbeModel model, Scene scene)
    : VirtualProbe(AsBuiltProbe{std::move(model), {}}, std::move(scene)) {}

VirtualProbe::VirtualProbe(AsBuiltProbe as_built, Scene scene)
    : model_(std::move(as_built.model)), optics_(as_built.optics), scene_(std::move(scene)) {
  model_.Validate();
  optics_.Validate();
  if (!scene_.workpiece) throw SceneError("scene: no workpiece");
}

VirtualProbe::Pixel VirtualProbe::Trace(const Pose3& mcs_from_probe,
                                        const Vec2& pixel,
                                        bool laser) const {
  Pixel px;
  const Vec2 xy = model_.camera.Undistort(pixel);
  const Vec3 dir_probe = Vec3(xy.x(), xy.y(), 1.0).normalized();
  const Vec3 origin_probe = optics_.WindowShift(dir_probe);
  const Ray ray{mcs_from_probe * origin_probe, mcs_from_probe.linear() * dir_probe};
  const auto hit = scene_.FirstHit(ray);
  if (!hit) return px;
  px.hit = true;
  const Vec3 point_mcs = ray.origin + hit->t * ray.direction;
  const Vec3 normal_probe = mcs_from_probe.linear().transpose() * hit->normal;
  px.point_in_probe = origin_probe + hit->t * dir_probe;
  px.reflectance = hit->reflectance;
  const Vec3 to_camera = -dir_probe;
  px.led_response = Reflected(hit->reflectance, hit->gloss, normal_probe, to_camera, to_camera);
  if (!laser) return px;  // LED light comes from the camera: no shadow to test
  px.sheet_column = model_.projector.SheetColumnOf(px.point_in_probe);
  const Vec3 to_projector = (model_.projector.Center() - px.point_in_probe).normalized();
  px.laser_response =
      Reflected(hit->reflectance, hit->gloss, normal_probe, to_projector, to_camera);
  const Vec3 projector_mcs = mcs_from_probe * model_.projector.Center();
  px.lit = normal_probe.dot(to_projector) > 0.0 && !scene_.Blocked(point_mcs, projector_mcs);
  return px;
}

// Reflectance x cos(view) per pixel for the LED frame: the pixel centre's, or on an edge (a
// 4-neighbour has another reflectance, misses the workpiece or answers more than
// kLedStepFraction differently) the mean over n x n sub-pixel rays. cos(view) varies smoothly and
// needs no more than the centre.
constexpr double kLedStepFraction = 0.2;

std::vector<double> VirtualProbe::LedResponse(const Pose3& pose,
                                              const SweepOptions& o,
                                              const std::vector<Pixel>& pixels) const {
  const int w = o.aoi.width, h = o.aoi.height, ss = std::max(1, o.led_supersampling);
  const auto value = [](const Pixel& p) { return p.hit ? p.led_response : 0.0; };
  std::vector<double> out(pixels.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      out[i] = value(pixels[i]);
      if (ss == 1) continue;
      bool edge = false;
      for (auto [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int xn = x + dx, yn = y + dy;
        if (xn < 0 || yn < 0 || xn >= w || yn >= h) continue;
        const Pixel& q = pixels[static_cast<size_t>(yn) * w + xn];
        // A reflectance or a depth edge (the lit face against one seen edge-on, or nothing).
        edge |= q.hit != pixels[i].hit || q.reflectance != pixels[i].reflectance ||
                std::abs(value(q) - value(pixels[i])) >
                    kLedStepFraction * std::max(value(q), value(pixels[i]));
      }
      if (!edge) continue;
      double sum = 0.0;
      for (int a = 0; a < ss; ++a) {
        for (int b = 0; b < ss; ++b) {
          const Vec2 sub(o.aoi.x0 + x - 0.5 + (a + 0.5) / ss, o.aoi.y0 + y - 0.5 + (b + 0.5) / ss);
          sum += value(Trace(pose, sub, false));
        }
      }
      out[i] = sum / (ss * ss);
    }
  }
  return out;
}

std::optional<Vec3> VirtualProbe::SurfaceAt(const Capture& capture, const Vec2& pixel) const {
  const Pixel px = Trace(McsFromProbe(capture), pixel);
  if (!px.hit) return std::nullopt;
  return px.point_in_probe;
}

void VirtualProbe::ColumnsReaching(
    const Capture& capture, const probe_fw::Aoi& aoi, double* first, double* last, int grid) const {
  *first = INFINITY, *last = -INFINITY;
  grid = std::max(grid, 2);
  for (int i = 0; i < grid; ++i) {
    for (int k = 0; k < grid; ++k) {
      const int dx = i + 1 == grid ? aoi.width - 1 : i * aoi.width / (grid - 1);
      const int dy = k + 1 == grid ? aoi.height - 1 : k * aoi.height / (grid - 1);
      const auto p = SurfaceAt(capture, Vec2(aoi.x0 + dx, aoi.y0 + dy));
      if (!p) continue;
      const double column = model_.projector.CommandedColumnOf(*p);
      *first = std::min(*first, column), *last = std::max(*last, column);
    }
  }
  if (!std::isfinite(*first)) throw SceneError("scene: the AOI sees no surface of the workpiece");
  *first = std::clamp(std::floor(*first) - 3.0, 0.0, model_.projector.columns - 1.0);
  *last = std::clamp(std::ceil(*last) + 3.0, *first, model_.projector.columns - 1.0);
}

std::optional<double> VirtualProbe::TrueStripeCentre(
    const Capture& capture, double column, int row, int x_begin, int x_end) const {
  const Pose3 pose = McsFromProbe(capture);
  const double actual = model_.projector.ActualColumn(column);
  auto offset = [&](double x, bool* ok) {
    const Pixel px = Trace(pose, Vec2(x, row));
    *ok = px.hit && px.lit;
    return px.sheet_column - actual;
  };
  bool ok_prev = false;
  double f_prev = offset(x_begin, &ok_prev);
  for (int x = x_begin + 1; x < x_end; ++x) {
    bool ok = false;
    const double f = offset(x, &ok);
    if (ok && ok_prev && (f_prev <= 0.0) != (f <= 0.0) && std::abs(f - f_prev) < 10.0) {
      double lo = x - 1, hi = x, f_lo = f_prev;
      while (hi - lo > 1e-6) {
        const double mid = 0.5 * (lo + hi);
        bool ok_mid = false;
        const double f_mid = offset(mid, &ok_mid);
        if (!ok_mid) return std::nullopt;
        if ((f_mid <= 0.0) == (f_lo <= 0.0))
          lo = mid, f_lo = f_mid;
        else
          hi = mid;
      }
      return 0.5 * (lo + hi);
    }
    f_prev = f, ok_prev = ok;
  }
  return std::nullopt;
}

struct VirtualProbe::Sheet {
  double gx = 0.0, gy = 0.0;  // d column / d pixel along the row and along the column
  double width_cols = 0.0;    // the sheet's 1/e^2 half-width on this pixel, defocus included
  double gain = 1.0;          // design width / width: a blurred stripe carries the same light
};

// How far the projector column changes across a pixel, for the integration of the sheet over
// the pixel's area: along the row and along the column, each the one-sided difference of smaller
// magnitude (a depth step, a neighbour on another surface, must not widen the stripe). Defocus
// (thin lens, camera.focus_distance_mm): a point at depth z is a disc of diameter
// b = D z_i |1/z - 1/z_f| on the sensor (D = f / N the pupil, z_i = f = fx pitch the pinhole's
// image distance); its spread across the stripe, sigma = b / 4, widens the Gaussian sheet in
// quadrature. Along the stripe the blur changes nothing a straight stripe would show.
std::vector<VirtualProbe::Sheet> VirtualProbe::SheetAcrossPixels(const std::vector<Pixel>& pixels,
                                                                 int w,
                                                                 int h) const {
  const auto derivative = [&](size_t i, int at, int limit, std::ptrdiff_t stride) {
    double best = INFINITY;
    for (int side : {-1, 1}) {
      const std::ptrdiff_t j = static_cast<std::ptrdiff_t>(i) + side * stride;
      if (at + side < 0 || at + side >= limit || !pixels[static_cast<size_t>(j)].hit) continue;
      const double d =
          side * (pixels[static_cast<size_t>(j)].sheet_column - pixels[i].sheet_column);
      if (std::abs(d) < std::abs(best)) best = d;
    }
    return std::isfinite(best) ? best : 0.0;
  };
  const auto& cam = model_.camera;
  const bool defocus = cam.f_number > 0.0 && cam.focus_distance_mm > 0.0;
  const double disc_px_per_dioptre = cam.fx_px * cam.fx_px * cam.pixel_pitch_mm / cam.f_number;
  const double w0 = model_.laser.sheet_halfwidth_cols;
  std::vector<Sheet> out(pixels.size());
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      Sheet& s = out[i];
      s.width_cols = w0;
      if (!pixels[i].hit) continue;
      s.gx = derivative(i, x, w, 1), s.gy = derivative(i, y, h, w);
      if (!defocus) continue;
      const double depth = pixels[i].point_in_probe.z();
      const double disc_px =
          disc_px_per_dioptre * std::abs(1.0 / depth - 1.0 / cam.focus_distance_mm);
      const double sigma_cols = 0.25 * disc_px * std::hypot(s.gx, s.gy);
      s.width_cols = std::hypot(w0, 2.0 * sigma_cols);
      s.gain = w0 / s.width_cols;
    }
  }
  return out;
}

// One laser frame's light through the coherent imager: the sheet's irradiance at every
// sub-sample of a lit pixel, the column interpolated by the pixel's gradient.
void VirtualProbe::SpeckledSheet(const std::vector<Pixel>& pixels,
                                 const std::vector<Sheet>& sheets,
                                 int w,
                                 int h,
                                 double actual_column,
                                 SpeckleImager* imager,
                                 std::vector<double>* laser_e) const {
  const int q = imager->Oversampling();
  const size_t row_stride = static_cast<size_t>(w) * q;
  std::vector<float>& irradiance = imager->Irradiance();
  const double peak = model_.noise.laser_peak_e;
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const Pixel& p = pixels[i];
      const Sheet& s = sheets[i];
      const double a = p.sheet_column - actual_column;
      if (!p.lit || std::abs(a) > 3.0 * s.width_cols + std::abs(s.gx) + std::abs(s.gy)) continue;
      const double scale = peak * p.laser_response * s.gain;
      const double k = -2.0 / (s.width_cols * s.width_cols);
      for (int b = 0; b < q; ++b) {
        const double dy = (b + 0.5) / q - 0.5;
        for (int c = 0; c < q; ++c) {
          const double u = a + s.gx * ((c + 0.5) / q - 0.5) + s.gy * dy;
          irradiance[(static_cast<size_t>(y) * q + b) * row_stride + static_cast<size_t>(x) * q +
                     c] = static_cast<float>(scale * std::exp(k * u * u));
        }
      }
    }
  }
  imager->Image(laser_e);
}

// The frames of one capture from per-pixel signals [e-]: the exposure, shot and read noise
// (Gaussian, each frame from its own seed), the camera's gain and clipping.
struct VirtualProbe::Frames {
  const VirtualProbe& probe;
  const SweepOptions& o;
  const std::vector<Pixel>& pixels;
  std::vector<Sheet> sheets;

  const probe_fw::NoiseModel& noise() const { return probe.model_.noise; }

  double Ambient(size_t i) const {
    return noise().ambient_e * (pixels[i].hit ? pixels[i].reflectance : kBackgroundFactor);
  }

  template <class Signal>
  Frame Make(double laser_column, std::uint64_t index, Signal signal_e) const {
    const probe_fw::CameraModel& camera = probe.model_.camera;
    const double gain_dn_per_e = camera.MaxLevel() / noise().full_well_e;
    const double read_e = noise().read_noise_e;
    Frame f;
    f.aoi = o.aoi;
    f.bit_depth = camera.bit_depth;
    f.laser_column = laser_column;
    f.pixels.resize(pixels.size());
    Gaussian gauss(FrameSeed(o.seed, index));
    for (size_t i = 0; i < pixels.size(); ++i) {
      double e = o.exposure * signal_e(i, gauss);
      if (o.noise) e += gauss() * std::sqrt(std::max(e, 0.0) + read_e * read_e);
      const double dn = std::round(e * gain_dn_per_e);
      f.pixels[i] = static_cast<std::uint16_t>(std::clamp(dn, 0.0, double(camera.MaxLevel())));
    }
    return f;
  }

  // A laser frame with speckle from the coherent imager (the surface's phase, the pupil).
  Frame Coherent(double column,
                 std::uint64_t index,
                 double actual,
                 const std::vector<GhostSplat>& ghosts,
                 SpeckleImager* coherent,
                 std::vector<double>* laser_e) const {
    const int w = o.aoi.width, h = o.aoi.height;
    SplatGhosts(ghosts, actual, probe.model_.laser.sheet_halfwidth_cols, w, h,
                coherent->Oversampling(), coherent->Irradiance().data());
    probe.SpeckledSheet(pixels, sheets, w, h, actual, coherent, laser_e);
    return Make(column, index, [&](size_t i, Gaussian&) { return Ambient(i) + (*laser_e)[i]; });
  }

  // A laser frame with the sheet integrated over each pixel and speckle as a multiplicative
  // Gaussian per pixel.
  Frame Incoherent(double column,
                   std::uint64_t index,
                   double actual,
                   const std::vector<GhostSplat>& ghosts,
                   std::vector<float>* ghost_e) const {
    if (!ghosts.empty()) {
      ghost_e->assign(pixels.size(), 0.0f);
      SplatGhosts(ghosts, actual, probe.model_.laser.sheet_halfwidth_cols, o.aoi.width,
                  o.aoi.height, 1, ghost_e->data());
    }
    return Make(column, index, [&](size_t i, Gaussian& gauss) {
      const Pixel& p = pixels[i];
      const Sheet& sh = sheets[i];
      double laser = ghost_e->empty() ? 0.0 : (*ghost_e)[i];
      if (p.lit) {
        const double g = sh.gain * PixelAveragedSheet(p.sheet_column - actual,
                                                      std::hypot(sh.gx, sh.gy), sh.width_cols);
        laser += noise().laser_peak_e * p.laser_response * g;
      }
      if (laser <= 0.0) return Ambient(i);
      double speckle = 1.0;
      if (o.noise) speckle = std::max(0.0, 1.0 + noise().speckle_contrast * gauss());
      return Ambient(i) + laser * speckle;
    });
  }

  // One frame per column, first + i * step, as the firmware plans a sweep (agent.h: PlanSweep).
  std::vector<Frame> Laser(const std::vector<GhostSplat>& ghosts) const {
    std::vector<Frame> frames;
    if (!o.laser_frames) return frames;
    std::unique_ptr<SpeckleImager> coherent;
    if (o.noise && CoherentSpeckle(probe.model_)) {
      coherent = std::make_unique<SpeckleImager>(
          o.aoi.width, o.aoi.height, AiryRadiusPx(probe.model_), noise().speckle_contrast,
          FrameSeed(o.seed, kSurfacePhaseStream));
    }
    std::vector<double> laser_e;
    std::vector<float> ghost_e;
    const auto steps =
        static_cast<std::uint64_t>((o.last_column - o.first_column) / o.column_step + 1e-9);
    for (std::uint64_t index = 1; index <= steps + 1; ++index) {
      const double column = o.first_column + static_cast<double>(index - 1) * o.column_step;
      const double actual = probe.model_.projector.ActualColumn(column);
      frames.push_back(coherent ? Coherent(column, index, actual, ghosts, coherent.get(), &laser_e)
                                : Incoherent(column, index, actual, ghosts, &ghost_e));
    }
    return frames;
  }
};

RenderedCapture VirtualProbe::Render(const Capture& capture, const SweepOptions& o) const {
  CheckSweep(model_, o);
  const Pose3 pose = McsFromProbe(capture);
  const int w = o.aoi.width, h = o.aoi.height;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  std::vector<Pixel> pixels(n);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      pixels[static_cast<size_t>(y) * w + x] =
          Trace(pose, Vec2(o.aoi.x0 + x, o.aoi.y0 + y), o.laser_frames);
    }
  }
  const Frames frames{*this, o, pixels, SheetAcrossPixels(pixels, w, h)};
  const std::vector<double> led = LedResponse(pose, o, pixels);
  RenderedCapture out;
  out.led = frames.Make(-1.0, 0, [&](size_t i, Gaussian&) {
    return frames.Ambient(i) + model_.noise.led_e * led[i];
  });
  out.ghosts = Interreflections(pose, o, pixels);
  out.laser = frames.Laser(out.ghosts);
  out.truth.resize(n);
  for (size_t i = 0; i < n; ++i) {
    out.truth[i] = {pixels[i].hit, pixels[i].lit, pixels[i].point_in_probe,
                    model_.projector.CommandedColumn(pixels[i].sheet_column)};
  }
  return out;
}

}  // namespace mlp::sim
