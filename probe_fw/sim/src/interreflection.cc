// One specular inter-reflection (issue 16): light of the sheet that a glossy face reflects onto
// another face the camera sees - a bore's far wall lit by its near wall, a pocket's corner, a
// step. Traced forward from the projector: the sheet is sampled over its columns and along its
// fan, each sample's first hit reflects into its microfacet lobe (GGX importance sampling,
// Walter et al., EGSR 2007, eqs. 35-41), and where that light lands and the camera sees it, it
// becomes a splat: a pixel, the column that sends it and the electrons it gives. Per frame the
// splats of the columns near the lit one are added to the image, so the ghost stripe moves with
// the sweep as a real one does. The diffuse part of the first face's light is not followed (a
// wide, weak glow, not a stripe), nor light that bounces twice.

#include "mlp/base/units.h"
#include "mlp/sim/brdf.h"
#include "mlp/sim/render.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "pixel.h"

namespace mlp::sim {
namespace {

// The lobe's samples per ray: a near-mirror (alpha below kSharpLobe) takes 9 directions (3 x 3
// strata of (xi1, xi2)) on every ray of the dense grid, for a sharp ghost; a rough lobe spreads
// its ghost over many pixels and takes 16 (4 x 4) on every kRoughStride-th ray along the fan,
// weighted up by as much (4 reflected rays per ray of the sheet).
constexpr double kSharpLobe = 0.03;
constexpr int kRoughStride = 4;
constexpr double kNudgeMm = 1e-4;  // leave the first face before tracing the reflected ray

// A reflected direction from the lobe of a face with normal n lit from `to_light`, and the
// fraction of the light it carries (Fresnel x masking, over the sampling density); 0: lost.
double SampleLobe(
    const Gloss& g, const Vec3& n, const Vec3& to_light, double xi1, double xi2, Vec3* reflected) {
  const double a2 = g.roughness * g.roughness;
  const double cos_h = std::sqrt((1.0 - xi1) / (1.0 - xi1 + a2 * xi1));
  const double sin_h = std::sqrt(std::max(0.0, 1.0 - cos_h * cos_h));
  const Vec3 t1 = n.unitOrthogonal(), t2 = n.cross(t1);
  const double phi = 2.0 * M_PI * xi2;
  const Vec3 h = cos_h * n + sin_h * (std::cos(phi) * t1 + std::sin(phi) * t2);
  const double l_h = to_light.dot(h);
  if (l_h <= 0.0) return 0.0;
  *reflected = 2.0 * l_h * h - to_light;
  const double cos_l = n.dot(to_light), cos_r = n.dot(*reflected);
  if (cos_l <= 0.0 || cos_r <= 0.0) return 0.0;
  return SchlickFresnel(g.specular_f0, l_h) * SmithG1(cos_l, a2) * SmithG1(cos_r, a2) * l_h /
         (cos_l * cos_h);
}

}  // namespace

bool VirtualProbe::SeenAt(const Pose3& mcs_from_probe,
                          const probe_fw::Aoi& aoi,
                          const Vec3& point_mcs,
                          geometry::Vec2* pixel) const {
  constexpr double kSameMm = 1e-4;
  const Vec3 q = mcs_from_probe.inverse() * point_mcs;
  if (q.z() <= 0.0) return false;
  const auto& cam = model_.camera;
  geometry::Vec2 px = cam.Project(q);
  for (int it = 0; it < 5; ++it) {  // the window shifts rays: correct the pinhole's guess
    if (px.x() < aoi.x0 - 0.5 || px.y() < aoi.y0 - 0.5 || px.x() > aoi.x0 + aoi.width - 0.5 ||
        px.y() > aoi.y0 + aoi.height - 0.5) {
      return false;
    }
    const Pixel seen = Trace(mcs_from_probe, px, false);
    if (!seen.hit) return false;
    if ((seen.point_in_probe - q).norm() < kSameMm) {
      *pixel = px;
      return true;
    }
    px += cam.Project(q) - cam.Project(seen.point_in_probe);
  }
  return false;  // another surface hides the point
}

// The stripe's light reflected off one glossy face onto another that the camera sees.
struct VirtualProbe::Ghosts {
  const VirtualProbe& probe;
  const Pose3& pose;
  const SweepOptions& o;

  // The fan's part to sample as tan(angle along the sheet): what the AOI sees, and half as much
  // again on each side (the face that reflects may be out of view). False when nothing is seen.
  bool FanRange(const std::vector<Pixel>& pixels, double* t_lo, double* t_hi) const {
    const auto& proj = probe.model_.projector;
    const Pose3 projector_from_probe = proj.camera_from_projector.inverse();
    *t_lo = INFINITY, *t_hi = -INFINITY;
    for (const Pixel& p : pixels) {
      if (!p.hit) continue;
      const Vec3 q = projector_from_probe * p.point_in_probe;
      *t_lo = std::min(*t_lo, q.y() / q.z()), *t_hi = std::max(*t_hi, q.y() / q.z());
    }
    if (!(*t_hi > *t_lo)) return false;
    const double fan = std::tan(proj.fan_half_angle_deg / base::kDegPerRad), span = *t_hi - *t_lo;
    *t_lo = std::max(-fan, *t_lo - 0.5 * span), *t_hi = std::min(fan, *t_hi + 0.5 * span);
    return true;
  }

  // One bounce of a cell's light `cell_e0_mm2` (sheet-centre irradiance x mm^2) hitting the
  // glossy face at `first`: stratified samples of its lobe, each seen where the reflected ray
  // lands, as a splat at sheet column u.
  void Bounce(const Ray& ray,
              const SurfaceHit& first,
              double u,
              double cell_e0_mm2,
              std::mt19937_64& engine,
              std::vector<GhostSplat>* out) const {
    const auto uniform = [&] { return static_cast<double>(engine() >> 11) * 0x1.0p-53; };
    const bool sharp = first.gloss.roughness < kSharpLobe;
    const int strata = sharp ? 3 : 4, samples = strata * strata;
    const double stride = sharp ? 1.0 : kRoughStride;
    const Vec3 p = ray.origin + first.t * ray.direction;
    const Vec3 camera_mcs = pose.translation();
    const auto& camera = probe.model_.camera;
    for (int k = 0; k < samples; ++k) {
      Vec3 r;
      const int stratum_1 = k % strata, stratum_2 = k / strata;  // stratified (jittered) draws
      const double xi1 = (stratum_1 + uniform()) / strata;
      const double xi2 = (stratum_2 + uniform()) / strata;
      const double carried = SampleLobe(first.gloss, first.normal, -ray.direction, xi1, xi2, &r);
      if (carried <= 0.0) continue;
      const Ray bounce{p + kNudgeMm * first.normal, r};
      const auto second = probe.scene_.FirstHit(bounce);
      if (!second) continue;
      const Vec3 q = bounce.origin + second->t * r;
      geometry::Vec2 px;
      if (!probe.SeenAt(pose, o.aoi, q, &px)) continue;
      const Vec3 to_camera = (camera_mcs - q).normalized();
      const double cos_in = second->normal.dot(-r);
      const double cos_view = second->normal.dot(to_camera);
      if (cos_in <= 1e-6 || cos_view <= 1e-6) continue;
      // The pixel's footprint on the face [mm^2]: z^2 cos(off-axis) / (fx fy cos(view)).
      const Vec3 q_probe = pose.inverse() * q;
      const double footprint = q_probe.z() * q_probe.z() * (q_probe.z() / q_probe.norm()) /
                               (camera.fx_px * camera.fy_px * cos_view);
      const double response =
          Reflected(second->reflectance, second->gloss, second->normal, -r, to_camera) / cos_in;
      const double e = probe.model_.noise.laser_peak_e * response * cell_e0_mm2 * stride * carried /
                       samples / footprint;
      out->push_back({static_cast<float>(px.x() - o.aoi.x0), static_cast<float>(px.y() - o.aoi.y0),
                      static_cast<float>(u), static_cast<float>(e)});
    }
  }
};

std::vector<GhostSplat> VirtualProbe::Interreflections(const Pose3& pose,
                                                       const SweepOptions& o,
                                                       const std::vector<Pixel>& pixels) const {
  std::vector<GhostSplat> out;
  if (!o.interreflections || !scene_.workpiece->Glossy()) return out;
  const Ghosts ghosts{*this, pose, o};
  double t_lo = 0, t_hi = 0;
  if (!ghosts.FanRange(pixels, &t_lo, &t_hi)) return out;
  const auto& proj = model_.projector;
  const double w = model_.laser.sheet_halfwidth_cols, du = 0.5 * w;
  const double u_lo = proj.ActualColumn(o.first_column) - 3.0 * w;
  const double u_hi = proj.ActualColumn(o.last_column) + 3.0 * w;
  const int n_u = static_cast<int>(std::ceil((u_hi - u_lo) / du));
  // A regular grid, ~4.5 samples per pixel over the part seen (the stripe may run along either
  // axis), so a mirror's ghost is as smooth as the stripe; only the lobe is sampled at random.
  const int n_t = 9 * std::max(o.aoi.width, o.aoi.height);
  const double dt = (t_hi - t_lo) / n_t;
  std::mt19937_64 engine(o.seed ^ 0x6a09e667f3bcc908ULL);  // the ghost's own stream
  const Vec3 projector_mcs = pose * proj.Center();
  const Eigen::Matrix3d mcs_R_projector = pose.linear() * proj.camera_from_projector.linear();
  for (int i = 0; i < n_u; ++i) {
    for (int j = 0; j < n_t; ++j) {
      const double u = u_lo + (i + 0.5) * du, t = t_lo + (j + 0.5) * dt;
      const double a = (u + proj.SmileAt(t) - proj.c_px) / proj.f_px;
      const Vec3 d_proj(a, t, 1.0);
      const Ray ray{projector_mcs, mcs_R_projector * d_proj.normalized()};
      const auto first = scene_.FirstHit(ray);
      if (!first || first->gloss.specular_f0 <= 0.0) continue;
      if (first->gloss.roughness >= kSharpLobe && j % kRoughStride != 0) continue;
      // The cell's light in units of the sheet-centre irradiance E0 times mm^2: its solid angle
      // (du / f) dt / |d|^3 at the hit's distance (the model keeps E0 along the ray).
      const double cell = first->t * first->t * (du / proj.f_px) * dt / std::pow(d_proj.norm(), 3);
      ghosts.Bounce(ray, *first, u, cell, engine, &out);
    }
  }
  std::sort(out.begin(), out.end(),
            [](const GhostSplat& x, const GhostSplat& y) { return x.column < y.column; });
  return out;
}

void SplatGhosts(const std::vector<GhostSplat>& splats,
                 double actual_column,
                 double sheet_halfwidth_cols,
                 int width,
                 int height,
                 int oversampling,
                 float* image) {
  const double w = sheet_halfwidth_cols;
  auto it = std::lower_bound(splats.begin(), splats.end(), actual_column - 3.0 * w,
                             [](const GhostSplat& s, double column) { return s.column < column; });
  const int q = oversampling, W = width * q, H = height * q;
  for (; it != splats.end() && it->column <= actual_column + 3.0 * w; ++it) {
    const double offset = it->column - actual_column;
    const double e = it->electrons * std::exp(-2.0 * offset * offset / (w * w)) * q * q;
    // Pixel x's sub-samples sit at x - 1/2 + (a + 1/2) / q: sub-sample coordinate (x + 1/2) q -
    // 1/2.
    const double sx = (it->x + 0.5) * q - 0.5, sy = (it->y + 0.5) * q - 0.5;
    const int x0 = static_cast<int>(std::floor(sx)), y0 = static_cast<int>(std::floor(sy));
    const double fx = sx - x0, fy = sy - y0;
    for (int b = 0; b < 2; ++b) {
      for (int a = 0; a < 2; ++a) {
        const int x = x0 + a, y = y0 + b;
        if (x < 0 || y < 0 || x >= W || y >= H) continue;
        const double weight = (a ? fx : 1.0 - fx) * (b ? fy : 1.0 - fy);
        image[static_cast<size_t>(y) * W + x] += static_cast<float>(e * weight);
      }
    }
  }
}

}  // namespace mlp::sim
