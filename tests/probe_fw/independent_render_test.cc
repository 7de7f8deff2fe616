// The firmware (`mlp-fw run`) on frames from a line-laser renderer that shares no code with the
// project's virtual probe (probe_fw/sim): it reads the probe model file's documented fields
// itself, has its own pinhole + Brown-Conrady projection and light planes, and draws each
// frame's stripe as a pixel-integrated Gaussian where the light plane meets a flat face, not
// by ray casting. It also draws what the project's renderer does not: laser speckle correlated
// over a grain size, and a reflection ghost (a second, weaker stripe moving differently from
// the stripe as the mirror sweeps: light that left the light plane). Frames go to disk in the
// documented capture format; the cloud is checked against the face the renderer drew.

#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/frame_io.h"

#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "test_data.h"
#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

namespace mlp::test {
namespace {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;

const std::string kProbeFile = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";
const std::string kFw = mlp::test::Program("mlp-fw");

struct Camera {
  double fx = 0, fy = 0, cx = 0, cy = 0, k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  Vector2d Project(const Vector3d& p) const {
    const double x = p.x() / p.z(), y = p.y() / p.z(), r2 = x * x + y * y;
    const double radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
    const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
    return {fx * xd + cx, fy * yd + cy};
  }
};

// The MEMS projector: column u lights the plane x_p / z_p = (u - c) / f of the projector frame.
struct Projector {
  double f = 0, c = 0;
  Eigen::Matrix3d camera_R_projector = Eigen::Matrix3d::Identity();
  Vector3d centre = Vector3d::Zero();  // in the camera frame

  // The light plane n.X = d in the camera frame, n unit.
  void Plane(double u, Vector3d* n, double* d) const {
    *n = (camera_R_projector * Vector3d(1.0, 0.0, -(u - c) / f)).normalized();
    *d = n->dot(centre);
  }
};

struct Probe {
  std::string serial;
  Camera camera;
  Projector projector;
};

Probe ReadProbe(const std::string& path) {
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& c = j.at("camera");
  const auto& k = c.at("distortion");
  const auto& pr = j.at("projector");
  const auto& pose = pr.at("camera_from_projector");
  const auto num = [](const nlohmann::json& v) { return v.get<double>(); };
  Probe p;
  p.serial = j.at("serial").get<std::string>();
  p.camera = {num(c.at("fx_px")), num(c.at("fy_px")), num(c.at("cx_px")),
              num(c.at("cy_px")), num(k.at("k1")),    num(k.at("k2")),
              num(k.at("p1")),    num(k.at("p2")),    num(k.at("k3"))};
  const auto& r = pose.at("rotation_vector_rad");
  const Vector3d rv(num(r[0]), num(r[1]), num(r[2]));
  p.projector.f = num(pr.at("f_px"));
  p.projector.c = num(pr.at("c_px"));
  if (rv.norm() > 0)
    p.projector.camera_R_projector = Eigen::AngleAxisd(rv.norm(), rv.normalized()).matrix();
  const auto& t = pose.at("translation_mm");
  p.projector.centre = Vector3d(num(t[0]), num(t[1]), num(t[2]));
  return p;
}

// A flat face m.X = h in the camera frame (m unit).
struct Face {
  Vector3d m;
  double h = 0;
};

// Where the line lit by column u on the face crosses scan line `line` (a sensor row; a sensor
// column when `on_columns`): bisection along the 3-D line where the light plane meets the face,
// on its projection's coordinate across the scan lines. `along` is the other coordinate.
bool StripeCrossing(
    const Probe& p, const Face& face, double u, double line, bool on_columns, double* along) {
  Vector3d n;
  double d = 0;
  p.projector.Plane(u, &n, &d);
  const Vector3d dir = n.cross(face.m).normalized();
  Eigen::Matrix<double, 2, 3> a;
  a.row(0) = n.transpose();
  a.row(1) = face.m.transpose();
  const Vector3d x0 = a.transpose() * (a * a.transpose()).inverse() * Vector2d(d, face.h);
  const int across = on_columns ? 0 : 1;
  const auto line_of = [&](double s) { return p.camera.Project(x0 + s * dir)[across] - line; };
  double lo = -100, hi = 100;  // mm along the line: beyond any window at 120 mm
  if (line_of(lo) * line_of(hi) > 0) return false;
  while (hi - lo > 1e-9) {
    const double mid = 0.5 * (lo + hi);
    (line_of(lo) * line_of(mid) <= 0 ? hi : lo) = mid;
  }
  const Vector3d point = x0 + 0.5 * (lo + hi) * dir;
  if (point.z() <= 0) return false;
  *along = p.camera.Project(point)[1 - across];
  return true;
}

struct Look {
  int x0 = 824, y0 = 618, width = 400, height = 300;  // sensor window around the centre
  double peak_dn = 150, background_dn = 12, noise_dn = 2;
  double sigma_px = 1.4;                   // the stripe's Gaussian across the line
  double speckle_contrast = 0;             // std / mean of the multiplicative speckle
  double speckle_grain_px = 1.5;           // FWHM of the speckle's intensity autocorrelation
  double ghost_ratio = 0;                  // ghost peak / stripe peak; 0: no ghost
  double ghost_offset_px = 40;             // ghost's offset from the stripe mid-sweep
  double ghost_drift_px_per_column = 0.6;  // how that offset changes per column
  bool along_rows = false;  // the stripe runs along the rows (a probe turned by 90 deg)
};

// Fully developed speckle (complex Gaussian field low-passed by a Gaussian of sigma_k: the
// intensity's autocorrelation is a Gaussian of the same sigma) mixed with a uniform part to the
// contrast asked for; mean 1. Fixed in the image for the whole sweep: the face and the camera's
// aperture do not move, and a few milliradians of illumination change decorrelate it little.
std::vector<double> SpeckleField(const Look& look, std::mt19937& rng) {
  const int w = look.width, h = look.height;
  std::vector<double> out(static_cast<size_t>(w) * h, 1.0);
  if (look.speckle_contrast <= 0) return out;
  const double sigma_k = look.speckle_grain_px / 2.3548;
  const int r = static_cast<int>(std::ceil(4 * sigma_k));
  std::vector<double> kernel;
  for (int i = -r; i <= r; ++i) kernel.push_back(std::exp(-0.5 * i * i / (sigma_k * sigma_k)));
  std::normal_distribution<double> g(0.0, 1.0);
  const int W = w + 2 * r, H = h + 2 * r;
  std::vector<std::complex<double>> e(static_cast<size_t>(W) * H), t(e.size());
  for (auto& v : e) v = {g(rng), g(rng)};
  for (int y = 0; y < H; ++y)  // along rows, then along columns
    for (int x = r; x < W - r; ++x) {
      std::complex<double> s = 0;
      for (int i = -r; i <= r; ++i) s += kernel[i + r] * e[y * W + x + i];
      t[y * W + x] = s;
    }
  double mean = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::complex<double> s = 0;
      for (int i = -r; i <= r; ++i) s += kernel[i + r] * t[(y + r + i) * W + x + r];
      out[y * w + x] = std::norm(s);
      mean += out[y * w + x];
    }
  mean /= static_cast<double>(out.size());
  for (double& v : out) v = (1 - look.speckle_contrast) + look.speckle_contrast * v / mean;
  return out;
}

// Light from a stripe centred at xc, integrated over pixel x (peak 1 for a wide pixel-free line).
double PixelGaussian(double x, double xc, double sigma) {
  const double k = 1.0 / (std::sqrt(2.0) * sigma);
  return sigma * std::sqrt(M_PI / 2) *
         (std::erf((x + 0.5 - xc) * k) - std::erf((x - 0.5 - xc) * k));
}

// The sweep over the window: a frame every 2 columns while the stripe crosses the window. Scan
// lines are rows, or columns when the stripe runs along the rows; `along` runs across the stripe.
std::vector<probe_fw::Frame> RenderSweep(const Probe& p,
                                         const Face& face,
                                         const Look& look,
                                         unsigned seed) {
  std::mt19937 rng(seed);
  const std::vector<double> speckle = SpeckleField(look, rng);
  std::normal_distribution<double> noise(0.0, look.noise_dn);
  const bool on_columns = look.along_rows;
  const int lines = on_columns ? look.width : look.height;
  const int length = on_columns ? look.height : look.width;
  const int line0 = on_columns ? look.x0 : look.y0, along0 = on_columns ? look.y0 : look.x0;
  std::vector<double> columns;
  for (double u = 0; u < 1024; u += 2) {
    double a = 0;
    if (StripeCrossing(p, face, u, line0 + 0.5 * lines, on_columns, &a) && a > along0 + 12 &&
        a < along0 + length - 12)
      columns.push_back(u);
  }
  const double u_mid = columns.empty() ? 0 : 0.5 * (columns.front() + columns.back());
  std::vector<probe_fw::Frame> frames;
  for (double u : columns) {
    probe_fw::Frame f;
    f.aoi = {look.x0, look.y0, look.width, look.height};
    f.laser_column = u;
    f.pixels.resize(static_cast<size_t>(look.width) * look.height);
    for (int line = 0; line < lines; ++line) {
      double ac = -1e9;
      StripeCrossing(p, face, u, line0 + line, on_columns, &ac);
      const double ag = ac + look.ghost_offset_px + look.ghost_drift_px_per_column * (u - u_mid);
      for (int i = 0; i < length; ++i) {
        const double sa = along0 + i;
        const size_t at = on_columns ? static_cast<size_t>(i) * look.width + line
                                     : static_cast<size_t>(line) * look.width + i;
        const double light = PixelGaussian(sa, ac, look.sigma_px) +
                             look.ghost_ratio * PixelGaussian(sa, ag, look.sigma_px);
        const double v = look.background_dn + look.peak_dn * light * speckle[at] + noise(rng);
        f.pixels[at] = static_cast<std::uint16_t>(std::clamp(std::lround(v), 0L, 255L));
      }
    }
    frames.push_back(std::move(f));
  }
  return frames;
}

struct CloudCheck {
  size_t points = 0, beyond_50um = 0;
  double rms_um = 0, max_um = 0;
};

// `mlp-fw run` on the frames, its cloud against the face.
CloudCheck RunFirmware(const Probe& p,
                       const Face& face,
                       const std::vector<probe_fw::Frame>& frames,
                       const std::string& name,
                       const std::string& probe_file = kProbeFile) {
  const fs::path dir = fs::temp_directory_path() / ("mlp_independent_" + name);
  fs::remove_all(dir);
  probe_fw::WriteCaptureDir(dir.string(), {p.serial, "nominal-design", name}, frames, ".png");
  const std::string cloud = (dir / "cloud.ply").string();
  const int status = std::system((kFw + " run --probe " + probe_file + " --frames " + dir.string() +
                                  " --roi full --out " + cloud + " > /dev/null")
                                     .c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << name;
  CloudCheck c;
  const probe_fw::CloudFile file = probe_fw::ReadCloudPly(cloud);
  double sum2 = 0;
  for (size_t i = 0; i < file.quality.size(); ++i) {
    const Vector3d x(file.xyz[3 * i], file.xyz[3 * i + 1], file.xyz[3 * i + 2]);
    const double e_um = std::abs(face.m.dot(x) - face.h) * 1e3;
    sum2 += e_um * e_um;
    c.max_um = std::max(c.max_um, e_um);
    c.beyond_50um += e_um > 50;
  }
  c.points = file.quality.size();
  c.rms_um = c.points ? std::sqrt(sum2 / static_cast<double>(c.points)) : 0;
  std::printf("%-8s %zu frames: %zu points, %.2f um RMS, %.1f um max, %zu beyond 50 um\n",
              name.c_str(), frames.size(), c.points, c.rms_um, c.max_um, c.beyond_50um);
  // MLP_KEEP_FRAMES=1 keeps the frames and cloud to look at (mlp-fw stripes, an image viewer).
  if (!std::getenv("MLP_KEEP_FRAMES")) fs::remove_all(dir);
  return c;
}

// A face 120 mm ahead, turned 12 deg about the camera's y axis.
Face TiltedFace() {
  const Vector3d m = Eigen::AngleAxisd(12 * M_PI / 180, Vector3d::UnitY()) * Vector3d::UnitZ();
  return {m, m.dot(Vector3d(0, 0, 120))};
}

// The firmware's point scatter on nominal frames (2 DN noise, no speckle): the budget.
constexpr double kNominalRmsUm = 5.0;
constexpr double kNominalMaxUm = 25.0;
constexpr double kMinRowsWithAPoint = 0.95;  // of rows x frames

TEST(IndependentRenderer, TheFirmwareMeetsAFlatFaceItDidNotRender) {
  const Probe probe = ReadProbe(kProbeFile);
  const Face face = TiltedFace();
  const Look nominal;
  const auto frames = RenderSweep(probe, face, nominal, 11);
  ASSERT_GT(frames.size(), 20u);
  const CloudCheck c = RunFirmware(probe, face, frames, "nominal");
  EXPECT_GT(c.points, kMinRowsWithAPoint * nominal.height * static_cast<double>(frames.size()));
  EXPECT_LT(c.rms_um, kNominalRmsUm);
  EXPECT_LT(c.max_um, kNominalMaxUm);
}

}  // namespace
}  // namespace mlp::test

namespace mlp::test {
namespace {

// Laser speckle of contrast 0.3 with grains 1.5 px across (the case): the cloud's budget.
constexpr double kSpeckleRmsUm = 10.0;

TEST(IndependentRenderer, SpeckleWithAGrainSizeStaysWithinTheBudget) {
  const Probe probe = ReadProbe(kProbeFile);
  const Face face = TiltedFace();
  Look speckle;
  speckle.speckle_contrast = 0.3;
  const auto frames = RenderSweep(probe, face, speckle, 13);
  const CloudCheck c = RunFirmware(probe, face, frames, "speckle");
  EXPECT_GT(c.points, kMinRowsWithAPoint * speckle.height * static_cast<double>(frames.size()));
  EXPECT_LT(c.rms_um, kSpeckleRmsUm);
  EXPECT_EQ(c.beyond_50um, 0u);
}

// A ghost 6 px or more from the stripe triangulates 0.3 mm or more off the face here; stripe
// centres within 12 px of a ghost (where the sweep cannot tell them apart and the double-peak
// test rejects most of them) may still be pulled by 1-2 px: 94 um at most in 12 seeded runs with
// speckle, 52 um without.
constexpr double kGhostPointUm = 100.0;
constexpr double kKeptWithGhost = 0.8;  // of the nominal sweep's points

TEST(IndependentRenderer, NoReflectionGhostReachesTheCloudWhateverItsMotionOrTheSpeckle) {
  const Probe probe = ReadProbe(kProbeFile);
  const Face face = TiltedFace();
  const size_t nominal_points =
      RunFirmware(probe, face, RenderSweep(probe, face, {}, 11), "nominal").points;
  unsigned seed = 20;
  for (double contrast : {0.0, 0.3}) {
    for (double drift : {0.6, 0.0, -0.6, 1.5}) {  // px per column against the stripe
      Look ghost;
      ghost.ghost_ratio = 0.5;
      ghost.ghost_drift_px_per_column = drift;
      ghost.speckle_contrast = contrast;
      const CloudCheck c =
          RunFirmware(probe, face, RenderSweep(probe, face, ghost, seed++), "ghost");
      EXPECT_LT(c.max_um, kGhostPointUm) << "drift " << drift << ", speckle " << contrast;
      EXPECT_GT(c.points, kKeptWithGhost * static_cast<double>(nominal_points))
          << "drift " << drift << ", speckle " << contrast;
    }
  }
}

}  // namespace
}  // namespace mlp::test

namespace mlp::test {
namespace {

// The reference probe with its projector turned by 90 deg about the camera's axis (baseline along
// y): its stripe runs along the sensor's rows, as on a probe mounted turned or a wall seen
// edge-on. Written beside the test's frames; the firmware reads it as any probe model.
std::string TurnedProbeFile() {
  std::ifstream in(kProbeFile);
  nlohmann::json j = nlohmann::json::parse(in);
  auto& pose = j.at("projector").at("camera_from_projector");
  const auto& r = pose.at("rotation_vector_rad");
  const Vector3d rv(r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(M_PI / 2, Vector3d::UnitZ()).matrix();
  const Eigen::Matrix3d rotation =
      turn * (rv.norm() > 0 ? Eigen::AngleAxisd(rv.norm(), rv.normalized()).matrix()
                            : Eigen::Matrix3d::Identity());
  const Eigen::AngleAxisd aa(rotation);
  const Vector3d new_rv = aa.angle() * aa.axis();
  const auto& t = pose.at("translation_mm");
  const Vector3d new_t =
      turn * Vector3d(t[0].get<double>(), t[1].get<double>(), t[2].get<double>());
  pose["rotation_vector_rad"] = {new_rv.x(), new_rv.y(), new_rv.z()};
  pose["translation_mm"] = {new_t.x(), new_t.y(), new_t.z()};
  const fs::path path = fs::temp_directory_path() / "mlp_independent_turned_probe.json";
  std::ofstream(path) << j.dump(2);
  return path.string();
}

TEST(IndependentRenderer, AProbeTurnedBy90DegreesKeepsItsPoints) {
  const std::string file = TurnedProbeFile();
  const Probe probe = ReadProbe(file);
  const Face face = TiltedFace();
  Look look;
  look.along_rows = true;
  const auto frames = RenderSweep(probe, face, look, 31);
  ASSERT_GT(frames.size(), 20u);
  const CloudCheck nominal = RunFirmware(probe, face, frames, "turned", file);
  EXPECT_GT(nominal.points, kMinRowsWithAPoint * look.width * static_cast<double>(frames.size()));
  EXPECT_LT(nominal.rms_um, kNominalRmsUm);
  EXPECT_LT(nominal.max_um, kNominalMaxUm);
  look.speckle_contrast = 0.3;
  const CloudCheck speckled =
      RunFirmware(probe, face, RenderSweep(probe, face, look, 32), "turned_speckle", file);
  EXPECT_GT(speckled.points, kMinRowsWithAPoint * look.width * static_cast<double>(frames.size()));
  EXPECT_LT(speckled.rms_um, kSpeckleRmsUm);
  EXPECT_EQ(speckled.beyond_50um, 0u);
  look.ghost_ratio = 0.5;
  const CloudCheck ghost =
      RunFirmware(probe, face, RenderSweep(probe, face, look, 33), "turned_ghost", file);
  EXPECT_LT(ghost.max_um, kGhostPointUm);
  EXPECT_GT(ghost.points, kKeptWithGhost * static_cast<double>(nominal.points));
  fs::remove(file);
}

}  // namespace
}  // namespace mlp::test
