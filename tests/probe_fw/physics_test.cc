// The virtual probe's physics of real parts (issue 16, part 2) against theory: speckle grain and
// contrast from the aperture (Goodman 2007), the stripe centre's scatter against the fundamental
// limit of laser triangulation (Dorsch, Haeusler, Herrmann, Appl. Opt. 33(7):1306, 1994), the
// microfacet reflectance (glints saturate), and defocus (thin lens). The renderer may use the
// truth here: these are the renderer's own tests.

#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/brdf.h"
#include "mlp/sim/render.h"
#include "mlp/sim/speckle.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numeric>

#include "scenes.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::sim {
namespace {

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

struct Moments {
  double mean = 0.0, contrast = 0.0, neighbour_correlation = 0.0;
};

// Mean, std / mean and the correlation of horizontally adjacent pixels over the inner square
// [margin, size - margin) of a size x size image.
Moments Statistics(const std::vector<double>& e, int size, int margin) {
  double sum = 0.0, n = 0.0;
  for (int y = margin; y < size - margin; ++y)
    for (int x = margin; x < size - margin; ++x) sum += e[y * size + x], n += 1.0;
  Moments m;
  m.mean = sum / n;
  double var = 0.0, cov = 0.0;
  for (int y = margin; y < size - margin; ++y) {
    for (int x = margin; x < size - margin; ++x) {
      const double a = e[y * size + x] - m.mean, b = e[y * size + x + 1] - m.mean;
      var += a * a, cov += a * b;
    }
  }
  m.contrast = std::sqrt(var / n) / m.mean;
  m.neighbour_correlation = cov / var;
  return m;
}

// Theory for pixels of unit size under speckle of a circular pupil: the intensity's correlation
// coefficient at separation r is |2 J1(v) / v|^2, v = 3.8317 r / airy radius (Goodman 2007,
// eq. 5.73); a pixel's value is its mean over the pixel, so its variance and its covariance with
// the neighbour are that correlation averaged over pairs of points in the two pixels.
double PixelCorrelation(double airy_px, double shift_px) {
  constexpr int kN = 16;
  double sum = 0.0;
  for (int a = 0; a < kN; ++a)
    for (int b = 0; b < kN; ++b)
      for (int c = 0; c < kN; ++c)
        for (int d = 0; d < kN; ++d) {
          const double dx = (a - c) / double(kN) + shift_px, dy = (b - d) / double(kN);
          const double v = 3.8317059702075125 * std::hypot(dx, dy) / airy_px;
          const double amp = v < 1e-9 ? 1.0 : 2.0 * std::cyl_bessel_j(1.0, v) / v;
          sum += amp * amp;
        }
  return sum / std::pow(kN, 4);
}

// A uniformly lit rough face: the speckle's mean, contrast and grain are those of theory.
TEST(Speckle, GrainAndContrastFollowTheAperture) {
  constexpr int kSize = 160, kMargin = 12;
  constexpr double kIrradianceE = 1000.0;
  // Tolerances: ~1,000 grains in the window give ~3 % sampling error on each moment.
  constexpr double kMeanTol = 0.05, kContrastTol = 0.08, kCorrelationTol = 0.06;
  for (double airy_px : {1.0, 2.0}) {
    SpeckleImager full(kSize, kSize, airy_px, 1.0, 7), partial(kSize, kSize, airy_px, 0.3, 7);
    std::vector<double> e_full, e_partial;
    for (SpeckleImager* s : {&full, &partial}) {
      std::fill(s->Irradiance().begin(), s->Irradiance().end(), float(kIrradianceE));
      s->Image(s == &full ? &e_full : &e_partial);
    }
    const Moments m = Statistics(e_full, kSize, kMargin);
    const double k0 = PixelCorrelation(airy_px, 0.0), k1 = PixelCorrelation(airy_px, 1.0);
    std::printf("Airy %.1f px: mean %.1f e, contrast %.3f (theory %.3f), neighbour %.3f (%.3f)\n",
                airy_px, m.mean, m.contrast, std::sqrt(k0), m.neighbour_correlation, k1 / k0);
    EXPECT_NEAR(m.mean / kIrradianceE, 1.0, kMeanTol);
    EXPECT_NEAR(m.contrast / std::sqrt(k0), 1.0, kContrastTol);
    EXPECT_NEAR(m.neighbour_correlation, k1 / k0, kCorrelationTol);
    // Partly developed: 0.3 of the same surface's speckle plus 0.7 of the light added in
    // intensity (uniform here), so 0.3 of its fluctuation.
    const Moments p = Statistics(e_partial, kSize, kMargin);
    constexpr double kPartialTol = 0.003;  // the partly developed share set, 0.3
    EXPECT_NEAR(p.contrast * p.mean / (m.contrast * m.mean), 0.3, kPartialTol);
    EXPECT_NEAR(p.mean, 0.7 * kIrradianceE + 0.3 * m.mean, 0.003 * kIrradianceE);
  }
}

probe_fw::ProbeModel WithOptics(double f_number, double contrast, double focus_mm = 0.0) {
  probe_fw::ProbeModel m = probe_fw::LoadProbeModel(kReference);
  m.camera.f_number = f_number;
  m.camera.focus_distance_mm = focus_mm;
  m.noise.speckle_contrast = contrast;
  return m;
}

struct Scatter {
  double depth_rms_mm = 0.0, dorsch_mm = 0.0;
  int samples = 0;
};

// Each row's stripe centre by a plain centre of mass (no rejections: the renderer's speckle as
// it is) against the true centre, turned into the triangulated point's displacement along the
// light sheet; Dorsch's limit dz = C lambda / (2 pi sin u sin theta) at the same points.
Scatter RowCentreScatter(const VirtualProbe& probe, double contrast) {
  const Capture& capture = probe.scene().captures[0];
  SweepOptions o;
  o.aoi = {924, 668, 200, 120};
  o.first_column = 480.0, o.last_column = 550.0, o.column_step = 5.0;
  o.seed = 11;
  const RenderedCapture r = probe.Render(capture, o);
  const auto& m = probe.model();
  const double lambda_mm = m.laser.wavelength_nm * 1e-6;
  constexpr int kHalfWindowPx = 7;  // 3.5 x the stripe's 1/e^2 half-width (2 px)
  double ss = 0.0, mean = 0.0, dorsch = 0.0;
  Scatter out;
  std::vector<double> errors;
  for (const probe_fw::Frame& f : r.laser) {
    for (int row = 0; row < o.aoi.height; row += 1) {
      const int y = o.aoi.y0 + row;
      const auto truth = probe.TrueStripeCentre(capture, f.laser_column, y, o.aoi.x0 + 10,
                                                o.aoi.x0 + o.aoi.width - 10);
      if (!truth) continue;
      const int xc = static_cast<int>(std::lround(*truth)) - o.aoi.x0;
      if (xc - kHalfWindowPx - 3 < 0 || xc + kHalfWindowPx + 3 >= o.aoi.width) continue;
      const auto at = [&](int x) { return double(f.pixels[size_t(row) * o.aoi.width + x]); };
      const double background = 0.25 * (at(xc - kHalfWindowPx - 3) + at(xc - kHalfWindowPx - 2) +
                                        at(xc + kHalfWindowPx + 2) + at(xc + kHalfWindowPx + 3));
      double s0 = 0.0, s1 = 0.0;
      for (int x = xc - kHalfWindowPx; x <= xc + kHalfWindowPx; ++x) {
        s0 += at(x) - background, s1 += (at(x) - background) * (x + o.aoi.x0);
      }
      if (s0 <= 0.0) continue;
      const double centre = s1 / s0;
      const Vec3 p = probe_fw::Triangulate(m, centre, y, f.laser_column).value();
      const Vec3 p_true = probe_fw::Triangulate(m, *truth, y, f.laser_column).value();
      const double e = (p - p_true).norm() * (centre < *truth ? -1.0 : 1.0);
      errors.push_back(e), mean += e;
      const Vec3 to_camera = -p_true.normalized();
      const Vec3 to_projector = (m.projector.Center() - p_true).normalized();
      const double sin_theta = to_camera.cross(to_projector).norm();
      dorsch +=
          contrast * lambda_mm / (2.0 * M_PI * m.camera.ApertureSinAt(p_true.norm()) * sin_theta);
    }
  }
  out.samples = static_cast<int>(errors.size());
  mean /= out.samples;
  for (double e : errors) ss += (e - mean) * (e - mean);
  out.depth_rms_mm = std::sqrt(ss / out.samples);
  out.dorsch_mm = dorsch / out.samples;
  return out;
}

// Issue 16 part 2: the single-point depth scatter on a rough face agrees with Dorsch's limit
// within 30 % over three apertures (fully developed speckle, C = 1: the formula's case).
TEST(Speckle, StripeScatterMeetsTheDorschLimitOverThreeApertures) {
  constexpr double kAgreement = 0.30;
  for (double f_number : {4.0, 5.6, 8.0}) {
    const VirtualProbe probe(WithOptics(f_number, 1.0), testing::FlatScene(0.6, 50.0));
    const Scatter s = RowCentreScatter(probe, 1.0);
    std::printf("f/%.1f (grain %.2f px): depth scatter %.2f um, Dorsch %.2f um, ratio %.2f, n %d\n",
                f_number, 2.44 * 0.45e-3 * f_number / 0.00345, s.depth_rms_mm * 1e3,
                s.dorsch_mm * 1e3, s.depth_rms_mm / s.dorsch_mm, s.samples);
    ASSERT_GT(s.samples, 1000);
    EXPECT_NEAR(s.depth_rms_mm / s.dorsch_mm, 1.0, kAgreement) << "f/" << f_number;
  }
}

// The reflectance model: a matt face is Lambert's; the lobe's directional albedo stays below 1
// (energy is not created) and near its Fresnel reflectance when smooth, falling as it roughens
// (single-scattering microfacets lose the light that would scatter twice: Kulla and Conty,
// SIGGRAPH 2017 course); the lobe peaks in the mirror direction.
TEST(Brdf, LambertianLimitEnergyAndLobe) {
  const Vec3 n = Vec3::UnitZ();
  const Vec3 l = Vec3(std::sin(0.5), 0.0, std::cos(0.5));
  const Vec3 v = Vec3(-0.3, 0.2, 0.9).normalized();
  EXPECT_DOUBLE_EQ(Reflected(0.6, Gloss{}, n, l, v), 0.6 * std::cos(0.5));
  EXPECT_EQ(Reflected(0.6, Gloss{}, n, -l, v), 0.0);   // lit from behind
  const Vec3 away = Vec3(0.5, 0.3, 0.8).normalized();  // far from the mirror direction
  double smoother_albedo = 1.0;
  for (double alpha : {0.12, 0.25, 0.45}) {
    const Gloss g{0.55, alpha};
    // Directional albedo of the lobe: integral of f cos(view) over the hemisphere, midpoint rule
    // in (cos theta, phi).
    constexpr int kN = 400;
    double albedo = 0.0;
    for (int i = 0; i < kN; ++i) {
      const double mu = (i + 0.5) / kN, sin_t = std::sqrt(1.0 - mu * mu);
      for (int j = 0; j < kN; ++j) {
        const double phi = 2.0 * M_PI * (j + 0.5) / kN;
        const Vec3 w(sin_t * std::cos(phi), sin_t * std::sin(phi), mu);
        albedo += Reflected(0.0, g, n, l, w) / (M_PI * l.z()) * mu * (2.0 * M_PI / kN) / kN;
      }
    }
    std::printf("alpha %.2f: lobe albedo %.3f (F0 0.55)\n", alpha, albedo);
    EXPECT_LT(albedo, smoother_albedo);
    if (alpha < 0.2) {
      EXPECT_GT(albedo, 0.95 * g.specular_f0);
    }
    smoother_albedo = albedo;
    const Vec3 mirror(-l.x(), 0.0, l.z());
    EXPECT_GT(Reflected(0.0, g, n, l, mirror), 3.0 * Reflected(0.0, g, n, l, away));
  }
}

// A face turned so the projector's light reflects into the camera: ground steel glints and
// saturates the camera, a matt coated face under the same light does not.
TEST(Brdf, GroundSteelGlintsSaturateTheCamera) {
  const probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReference);
  Scene scene = testing::FlatScene(0.6, 50.0);
  const Pose3 mcs_from_probe = scene.captures[0].mcs_from_flange * scene.flange_from_probe;
  const Vec3 centre_mcs(0.3, -0.2, 0.0);  // below the probe
  const Vec3 centre_probe = mcs_from_probe.inverse() * centre_mcs;
  const Vec3 bisector_probe =
      ((model.projector.Center() - centre_probe).normalized() - centre_probe.normalized())
          .normalized();
  const Vec3 normal_mcs = mcs_from_probe.linear() * bisector_probe;
  SweepOptions o;
  const geometry::Vec2 px = model.camera.Project(centre_probe);
  o.aoi = {int(px.x()) - 60, int(px.y()) - 60, 120, 120};
  o.seed = 3;
  int saturated[2] = {0, 0};
  for (int finish = 0; finish < 2; ++finish) {
    const SolidPtr face = MakeHalfspace(centre_mcs, normal_mcs, 0.5);
    scene.workpiece =
        finish == 0 ? MakeFinish(face, Gloss{0.55, 0.12}, 0.08) : MakeFinish(face, Gloss{}, 0.8);
    const VirtualProbe probe(model, scene);
    double first = 0, last = 0;
    probe.ColumnsReaching(scene.captures[0], o.aoi, &first, &last);
    o.first_column = first, o.last_column = last, o.column_step = 4.0;
    for (const auto& f : probe.Render(scene.captures[0], o).laser)
      for (auto v : f.pixels) saturated[finish] += v == model.camera.MaxLevel();
  }
  std::printf("saturated pixels: ground steel %d, matt coated %d\n", saturated[0], saturated[1]);
  EXPECT_GT(saturated[0], 100);
  EXPECT_EQ(saturated[1], 0);
}

// Second moment [px^2] of row `row`'s profile around its peak (+-30 px; no shop light).
double RowVariancePx2(const probe_fw::Frame& f, int row) {
  const int w = f.aoi.width;
  const auto* line = &f.pixels[size_t(row) * w];
  const int peak = int(std::max_element(line, line + w) - line);
  double s0 = 0, s1 = 0, s2 = 0;
  for (int x = std::max(0, peak - 30); x <= std::min(w - 1, peak + 30); ++x) {
    const double v = line[x];
    s0 += v, s1 += v * x, s2 += v * x * x;
  }
  const double mean = s1 / s0;
  return s2 / s0 - mean * mean;
}

// Defocus (thin lens): the stripe of a face 20 mm nearer than the focus is wider, its variance
// across the stripe grown by (b / 4)^2, b = D z_i |1/z - 1/z_f| the blur disc.
TEST(Defocus, StripeWidensAsTheThinLensSays) {
  constexpr double kFNumber = 8.0, kVarianceTol = 0.12;
  const Scene scene = testing::FlatScene(0.6, 50.0);
  SweepOptions o;
  o.aoi = {980, 740, 100, 40};
  o.first_column = o.last_column = 515.0;
  o.noise = false;
  o.seed = 1;
  const auto render = [&](double focus_mm) {
    probe_fw::ProbeModel m = WithOptics(kFNumber, 0.0, focus_mm);
    m.noise.ambient_e = 0.0;
    m.camera.bit_depth = 12;  // fine levels: the wide stripe's flanks are not lost to rounding
    const VirtualProbe probe(m, scene);
    return probe.Render(scene.captures[0], o);
  };
  const RenderedCapture focused = render(120.0);
  const Vec3 p = focused.truth[20 * 100 + 50].point_in_probe;
  const probe_fw::ProbeModel m = WithOptics(kFNumber, 0.0);
  double var_focused = RowVariancePx2(focused.laser[0], 20);
  for (double focus_mm : {100.0, 140.0}) {
    const double disc_px = m.camera.fx_px * m.camera.fx_px * m.camera.pixel_pitch_mm / kFNumber *
                           std::abs(1.0 / p.z() - 1.0 / focus_mm);
    const double var = RowVariancePx2(render(focus_mm).laser[0], 20);
    std::printf(
        "focus %.0f mm, face at %.1f mm: blur disc %.2f px, variance %.2f -> %.2f px^2 "
        "(expected +%.2f)\n",
        focus_mm, p.z(), disc_px, var_focused, var, disc_px * disc_px / 16.0);
    EXPECT_NEAR((var - var_focused) / (disc_px * disc_px / 16.0), 1.0, kVarianceTol);
  }
}

// A mirror-like wall standing on a matt floor, facing the projector: the sheet of a column that
// meets the wall is reflected onto the floor beside it, where the camera sees a second stripe.
// For a near-mirror the ghost lies where the sheet of the projector's mirror image (about the
// wall's plane) meets the floor, and carries the light a mirror of Fresnel reflectance 1 sends:
// the wall's irradiance spread over the longer path, (r1 / (r1 + r2))^2.
struct WallScene {
  static constexpr double kWallXmm = -4.0, kFloorReflectance = 0.8;
  Scene scene;
  WallScene() {
    scene = testing::FlatScene(kFloorReflectance, 50.0);
    const SolidPtr wall =
        MakeFinish(MakeBox({-50, -50, -30}, {kWallXmm, 50, 30}, 0.5), Gloss{1.0, 0.005}, 0.0);
    scene.workpiece = MakeUnion({scene.workpiece, wall});
  }
  // The floor point (MCS) the camera sees at a sensor pixel.
  static Vec3 Floor(const VirtualProbe& probe, double x, double y) {
    const Capture& c = probe.scene().captures[0];
    return probe.McsFromProbe(c) * *probe.SurfaceAt(c, geometry::Vec2(x, y));
  }
  // Signed distance of a floor point to the mirror image of actual column u's light plane.
  static double ToMirroredSheet(const VirtualProbe& probe, double u, const Vec3& point_mcs) {
    const Pose3 pose = probe.McsFromProbe(probe.scene().captures[0]);
    Vec3 n_probe;
    double d_probe = 0.0;
    probe.model().projector.PlaneOf(u, &n_probe, &d_probe);
    Vec3 n = pose.linear() * n_probe;
    Vec3 on_plane = pose * probe.model().projector.Center();
    n.x() = -n.x();  // mirrored about the plane x = kWallXmm
    on_plane.x() = 2.0 * kWallXmm - on_plane.x();
    return n.dot(point_mcs - on_plane);
  }
  // The predicted ghost's sensor x on sensor row y (bisection along the row), NaN if none.
  static double GhostX(const VirtualProbe& probe, double u, double y, double x_lo, double x_hi) {
    double f_lo = ToMirroredSheet(probe, u, Floor(probe, x_lo, y));
    if ((f_lo > 0) == (ToMirroredSheet(probe, u, Floor(probe, x_hi, y)) > 0)) return NAN;
    while (x_hi - x_lo > 1e-4) {
      const double mid = 0.5 * (x_lo + x_hi), f = ToMirroredSheet(probe, u, Floor(probe, mid, y));
      if ((f > 0) == (f_lo > 0))
        x_lo = mid, f_lo = f;
      else
        x_hi = mid;
    }
    return 0.5 * (x_lo + x_hi);
  }
};

TEST(Interreflection, GhostOfAMirrorWallLiesAndShinesWhereTheMirrorImageSays) {
  constexpr double kPositionTolPx = 0.5, kLightTol = 0.1;
  probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReference);
  model.camera.bit_depth = 16;  // no clipping: the light is compared, not just seen
  model.noise.ambient_e = 0.0;
  const WallScene ws;
  const VirtualProbe probe(model, ws.scene);
  const Capture& capture = ws.scene.captures[0];
  // The floor right of the wall, seen from above.
  const geometry::Vec2 corner = model.camera.Project(probe.McsFromProbe(capture).inverse() *
                                                     Vec3(WallScene::kWallXmm, 0.0, 0.0));
  SweepOptions o;
  o.aoi = {int(corner.x()) + 4, int(corner.y()) - 40, 140, 80};
  o.noise = false;
  o.seed = 5;
  // A column whose sheet meets the wall about 4 mm up: the ghost falls ~2 mm right of it.
  const Vec3 wall_point = probe.McsFromProbe(capture).inverse() * Vec3(WallScene::kWallXmm, 0, 4);
  const double u = model.projector.CommandedColumnOf(wall_point);
  o.first_column = u, o.last_column = u + 1.0, o.column_step = 1.0;
  const RenderedCapture lit = probe.Render(capture, o);
  o.interreflections = false;
  const RenderedCapture plain = probe.Render(capture, o);
  ASSERT_FALSE(lit.ghosts.empty());
  const double gain = model.camera.MaxLevel() / model.noise.full_well_e;  // DN per e-
  int rows = 0;
  double worst_px = 0.0, light_ratio = 0.0;
  for (int row = 10; row < o.aoi.height - 10; row += 5) {
    const int y = o.aoi.y0 + row;
    const double predicted[2] = {
        WallScene::GhostX(probe, model.projector.ActualColumn(u), y, o.aoi.x0, o.aoi.x0 + 139),
        WallScene::GhostX(probe, model.projector.ActualColumn(u + 1), y, o.aoi.x0, o.aoi.x0 + 139)};
    ASSERT_TRUE(std::isfinite(predicted[0]) && std::isfinite(predicted[1]));
    // The ghost's centre of mass within 5 px of where the mirror image puts it (a window fixed
    // by the prediction, not by the brightest pixel, which flips between the two pixels of a
    // narrow ghost and truncates the lobe's uneven tails unevenly) and its light over the row.
    double centre[2] = {0, 0}, total[2] = {0, 0};
    for (int f = 0; f < 2; ++f) {
      const int at = static_cast<int>(std::lround(predicted[f])) - o.aoi.x0;
      double s0 = 0, s1 = 0;
      for (int x = 0; x < o.aoi.width; ++x) {
        const size_t i = size_t(row) * o.aoi.width + x;
        const double e = (double(lit.laser[f].pixels[i]) - plain.laser[f].pixels[i]) / gain;
        total[f] += e;
        if (std::abs(x - at) <= 5) s0 += e, s1 += e * (x + o.aoi.x0);
      }
      centre[f] = s1 / s0;
    }
    worst_px = std::max(
        {worst_px, std::abs(centre[0] - predicted[0]), std::abs(centre[1] - predicted[1])});
    // Light across the row: peak x (sheet's Gaussian integrated over the columns the row
    // crosses) = peak x w sqrt(pi / 2) / |du/dx|.
    const Vec3 q = WallScene::Floor(probe, predicted[0], y);
    const Pose3 pose = probe.McsFromProbe(capture);
    Vec3 source = pose * model.projector.Center();
    source.x() = 2.0 * WallScene::kWallXmm - source.x();  // the projector's mirror image
    const double path = (q - source).norm();
    const double t_wall = (WallScene::kWallXmm - source.x()) / (q.x() - source.x());
    const double r1 = t_wall * path;  // projector to wall = image to wall
    const double cos_floor = (source - q).normalized().z();
    const double peak_e = model.noise.laser_peak_e * WallScene::kFloorReflectance * cos_floor *
                          (r1 / path) * (r1 / path);
    const double du_dx = 1.0 / std::abs(predicted[1] - predicted[0]);
    const double expected = peak_e * model.laser.sheet_halfwidth_cols * std::sqrt(M_PI / 2) / du_dx;
    light_ratio += total[0] / expected;
    ++rows;
  }
  light_ratio /= rows;
  std::printf(
      "ghost: %zu splats, worst centre %.3f px from the mirror image's sheet over %d rows, "
      "light %.3f of a perfect mirror's\n",
      lit.ghosts.size(), worst_px, rows, light_ratio);
  EXPECT_LT(worst_px, kPositionTolPx);
  EXPECT_NEAR(light_ratio, 1.0, kLightTol);
}

}  // namespace
}  // namespace mlp::sim
