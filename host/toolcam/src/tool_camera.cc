#include "mlp/toolcam/tool_camera.h"

#include "mlp/base/files.h"
#include "mlp/base/raster.h"
#include "mlp/base/units.h"
#include "mlp/grey_image/grey_image.h"
#include "mlp/toolcam/tool_images.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "camera_json.h"
#include <nlohmann/json.hpp>

namespace mlp::toolcam {
namespace {

// Sub-pixel rows per pixel row, each at a random height within its share (stratified): a
// near-level edge's cover is then right on average, its error (up to 1/64 px, shared along
// the row) noise rather than a bias that follows the edge's sub-pixel height. With 8 fixed
// sub-rows a pin's blade ends were off by up to 1/16 px with their height, 0.0025 deg in the
// pitch measured from them; the 32 cost a quarter more time per image.
constexpr int kSubRows = 32;
constexpr int kBlurSamples = 5;  // angles over a pulse

[[noreturn]] void Fail(const std::string& what) { throw ToolError("tool camera: " + what); }
[[noreturn]] void Bad(const std::string& what) { throw ToolInputError("tool camera: " + what); }

// Adds `weight` times the share of each pixel column that [a, b] (pixel units; column u spans
// [u - 0.5, u + 0.5]) covers, into a difference array for the whole columns and `row` for the
// partial ones at its ends.
void AddSpan(
    double a, double b, double weight, std::vector<double>* row, std::vector<double>* diff) {
  const int w = static_cast<int>(row->size());
  a = std::max(a, -0.5), b = std::min(b, w - 0.5);
  if (b <= a) return;
  const int ua = static_cast<int>(std::floor(a + 0.5)), ub = static_cast<int>(std::floor(b + 0.5));
  if (ua == ub) {
    (*row)[static_cast<size_t>(ua)] += weight * (b - a);
    return;
  }
  (*row)[static_cast<size_t>(ua)] += weight * (ua + 0.5 - a);
  if (ub < w) (*row)[static_cast<size_t>(ub)] += weight * (b - (ub - 0.5));
  (*diff)[static_cast<size_t>(ua) + 1] += weight;
  (*diff)[static_cast<size_t>(ub)] -= weight;
}

std::vector<Drop> PlaceDrops(const ToolDescription& t,
                             const ToolCameraModel& c,
                             double turn,
                             std::mt19937& rng) {
  std::poisson_distribution<int> count(c.drops_per_frame);
  std::uniform_real_distribution<double> unit(0, 1);
  std::vector<Drop> drops;
  const int n = c.drops_per_frame > 0 ? count(rng) : 0;
  for (int i = 0; i < n; ++i) {
    Drop d;
    d.radius_mm = 0.01 + 0.03 * unit(rng);
    const double u = unit(rng) * (c.width_px - 1), v = unit(rng) * (c.height_px - 1);
    const geometry::Vec2 at = c.ToolFromPixel({u, v});
    d.h_mm = at.y();
    double lo = 0, hi = 0;
    // Stuck to the edge: on the flank of the side it fell on (a large tool shows only +y).
    if (unit(rng) < 0.5 && t.ShadowSpan(d.h_mm, turn, &lo, &hi))
      d.y_mm = at.x() >= 0 ? hi + d.radius_mm * (0.2 + 0.7 * unit(rng))
                           : lo - d.radius_mm * (0.2 + 0.7 * unit(rng));
    else
      d.y_mm = at.x();
    drops.push_back(d);
  }
  return drops;
}

// Shadow share of every pixel of a canvas square to the spindle (`c`'s roll is applied when
// resampling): the tool's (averaged over the pulse) and the drops', as the union of
// independent covers.
std::vector<double> Coverage(const ToolDescription& t,
                             const ToolCameraModel& c,
                             double turn,
                             double blur,
                             const std::vector<Drop>& drops,
                             std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0, 1);
  const double tan_pitch = std::tan(c.pitch_deg / base::kDegPerRad);
  const auto w = static_cast<size_t>(c.width_px);
  std::vector<double> cover(w * static_cast<size_t>(c.height_px), 0.0);
  std::vector<double> tool(w), tool_diff(w + 1), drop(w), drop_diff(w + 1);
  const double weight = 1.0 / (kSubRows * kBlurSamples);
  for (int v = 0; v < c.height_px; ++v) {
    std::fill(tool.begin(), tool.end(), 0.0), std::fill(tool_diff.begin(), tool_diff.end(), 0.0);
    std::fill(drop.begin(), drop.end(), 0.0), std::fill(drop_diff.begin(), drop_diff.end(), 0.0);
    for (int s = 0; s < kSubRows; ++s) {
      const double h = (c.tip_v_px - (v - 0.5 + (s + unit(rng)) / kSubRows)) * c.mm_per_px;
      for (int b = 0; b < kBlurSamples; ++b) {
        const double a = turn + blur * ((b + 0.5) / kBlurSamples - 0.5);
        const ShadowSpans spans = t.Shadow(h, a, tan_pitch);
        for (int k = 0; k < spans.count; ++k)
          AddSpan(spans.lo[k] / c.mm_per_px + c.axis_u_px, spans.hi[k] / c.mm_per_px + c.axis_u_px,
                  weight, &tool, &tool_diff);
      }
      if (c.glass_face_h_mm && h < *c.glass_face_h_mm)  // the glass block, across the image
        AddSpan(-0.5, static_cast<double>(w) - 0.5, 1.0 / kSubRows, &drop, &drop_diff);
      if (c.glass_side_y_mm) {  // the block's side face, along the image
        const double at = *c.glass_side_y_mm / c.mm_per_px + c.axis_u_px;
        if (*c.glass_side_y_mm > 0)
          AddSpan(at, static_cast<double>(w) - 0.5, 1.0 / kSubRows, &drop, &drop_diff);
        else
          AddSpan(-0.5, at, 1.0 / kSubRows, &drop, &drop_diff);
      }
      for (const Drop& d : drops) {
        const double dh = h - d.h_mm;
        if (std::abs(dh) >= d.radius_mm) continue;
        const double half = std::sqrt(d.radius_mm * d.radius_mm - dh * dh);
        AddSpan((d.y_mm - half) / c.mm_per_px + c.axis_u_px,
                (d.y_mm + half) / c.mm_per_px + c.axis_u_px, 1.0 / kSubRows, &drop, &drop_diff);
      }
    }
    double run_t = 0, run_d = 0;
    for (size_t u = 0; u < w; ++u) {
      run_t += tool_diff[u], run_d += drop_diff[u];
      const double ct = std::min(1.0, tool[u] + run_t), cd = std::min(1.0, drop[u] + run_d);
      cover[static_cast<size_t>(v) * w + u] = 1 - (1 - ct) * (1 - cd);
    }
  }
  return cover;
}

// Keys' cubic convolution weights (a = -0.5) for a sample at fraction f past the second of
// four: reproduces quadratics, so a blurred edge moves by far less than under bilinear
// resampling, whose error is periodic in the sub-pixel phase and, along an edge turned by a
// fraction of a degree (a whole period over hundreds of rows), biased the turn measured.
std::array<double, 4> CubicWeights(double f) {
  const auto near = [](double x) { return (1.5 * x - 2.5) * x * x + 1; };        // |x| <= 1
  const auto far = [](double x) { return ((-0.5 * x + 2.5) * x - 4) * x + 2; };  // 1 < |x| < 2
  return {far(1 + f), near(f), near(1 - f), far(2 - f)};
}

// The image from the canvas (square to the spindle, `margin` pixels wider on every side):
// each pixel's ideal position (ToolCameraModel::Undistort: the measurement's own lens
// model), its tool point with the camera's roll, that point's canvas pixel, cubic interpolation.
std::vector<double> Resample(const std::vector<double>& canvas,
                             const ToolCameraModel& c,
                             int margin) {
  const int w = c.width_px, h = c.height_px, cw = w + 2 * margin, ch = h + 2 * margin;
  std::vector<double> out(base::RasterSize(w, h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const geometry::Vec2 yh = c.ToolFromPixel(c.Undistort({x, y}));
      const double sx = std::clamp(yh.x() / c.mm_per_px + c.axis_u_px + margin, 1.0, cw - 3.001);
      const double sy = std::clamp(c.tip_v_px - yh.y() / c.mm_per_px + margin, 1.0, ch - 3.001);
      const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
      const std::array<double, 4> wx = CubicWeights(sx - x0), wy = CubicWeights(sy - y0);
      double sum = 0;
      for (int j = 0; j < 4; ++j) {
        const double* row = canvas.data() + base::RasterIndex(x0 - 1, y0 - 1 + j, cw);
        sum += wy[static_cast<size_t>(j)] *
               (wx[0] * row[0] + wx[1] * row[1] + wx[2] * row[2] + wx[3] * row[3]);
      }
      out[base::RasterIndex(x, y, w)] = sum;
    }
  return out;
}

}  // namespace

namespace {

// Brown's tangential shift at offset d from the lens' centre [px].
geometry::Vec2 TangentialShift(const ToolCameraModel& c, const geometry::Vec2& d) {
  const double corner = std::sqrt(c.Corner2()), x = d.x() / corner, y = d.y() / corner;
  const double rho2 = x * x + y * y, p1 = c.distortion_p1, p2 = c.distortion_p2;
  return corner * geometry::Vec2(2 * p1 * x * y + p2 * (rho2 + 2 * x * x),
                                 p1 * (rho2 + 2 * y * y) + 2 * p2 * x * y);
}

}  // namespace

double ToolCameraModel::Corner2() const {
  const double cx = (width_px - 1) / 2.0, cy = (height_px - 1) / 2.0;
  return cx * cx + cy * cy;
}

geometry::Vec2 ToolCameraModel::LensCentre() const {
  return {principal_u_px.value_or((width_px - 1) / 2.0),
          principal_v_px.value_or((height_px - 1) / 2.0)};
}

geometry::Vec2 ToolCameraModel::Undistort(const geometry::Vec2& px) const {
  const geometry::Vec2 centre = LensCentre(), d = px - centre;
  return centre +
         (d - TangentialShift(*this, d)) / (1 + distortion_k1 * d.squaredNorm() / Corner2());
}

geometry::Vec2 ToolCameraModel::Distort(const geometry::Vec2& ideal_px) const {
  // Undistort's inverse by fixed-point steps (each gains the distortion's share, < 1e-2).
  geometry::Vec2 px = ideal_px;
  for (int i = 0; i < 6; ++i) px += ideal_px - Undistort(px);
  return px;
}

geometry::Vec2 ToolCameraModel::ToolFromPixel(const geometry::Vec2& px) const {
  const double a = roll_deg / base::kDegPerRad, du = (px.x() - axis_u_px) * mm_per_px,
               dv = (tip_v_px - px.y()) * mm_per_px;
  return {std::cos(a) * du + std::sin(a) * dv, std::cos(a) * dv - std::sin(a) * du};
}

geometry::Vec2 ToolCameraModel::PixelFromTool(const geometry::Vec2& yh) const {
  const double a = roll_deg / base::kDegPerRad;
  const double du = std::cos(a) * yh.x() - std::sin(a) * yh.y(),
               dv = std::sin(a) * yh.x() + std::cos(a) * yh.y();
  return {axis_u_px + du / mm_per_px, tip_v_px - dv / mm_per_px};
}

void ToolCameraModel::Validate() const {
  if (width_px < 16 || height_px < 16 || width_px > 8192 || height_px > 8192)
    Bad("the image must be 16..8192 px each way");
  if (!(mm_per_px > 0)) Bad("mm_per_px must be > 0");
  if (!(bright > dark) || dark < 0 || bright > 255) Bad("0 <= dark < bright <= 255");
  if (!(noise_sigma >= 0) || !(psf_sigma_px >= 0) || !(drops_per_frame >= 0))
    Bad("noise, blur and drops must be >= 0");
  if (!(std::abs(distortion_k1) < 0.05)) Bad("distortion_k1 must be under 5 %");
  if (!(std::abs(distortion_p1) < 0.01) || !(std::abs(distortion_p2) < 0.01))
    Bad("distortion_p1 and distortion_p2 must be under 1 %");
  const geometry::Vec2 centre = LensCentre();
  if (!(centre.x() >= 0 && centre.x() <= width_px - 1 && centre.y() >= 0 &&
        centre.y() <= height_px - 1))
    Bad("principal_u_px and principal_v_px must lie in the image");
  if (!(std::abs(roll_deg) <= 5) || !(std::abs(pitch_deg) <= 5))
    Bad("roll_deg and pitch_deg must be within 5 deg");
}

ToolFrame RenderToolFrame(const ToolDescription& tool,
                          const ToolCameraModel& c,
                          double turn_rad,
                          double blur_rad,
                          std::mt19937& rng) {
  c.Validate();
  ToolFrame f;
  f.drops = PlaceDrops(tool, c, turn_rad, rng);
  // A canvas square to the spindle, wide enough for the roll to turn it inside the image: the
  // roll turns about the axis' point at the tip row (often outside the image), so each corner
  // moves by its distance from there times the roll.
  double corner = 0;
  for (const double u : {0.0, c.width_px - 1.0})
    for (const double v : {0.0, c.height_px - 1.0})
      corner = std::max(corner, std::hypot(u - c.axis_u_px, v - c.tip_v_px));
  const int margin =
      2 + static_cast<int>(std::ceil(corner * std::abs(std::sin(c.roll_deg / base::kDegPerRad))));
  ToolCameraModel canvas = c;
  canvas.width_px += 2 * margin, canvas.height_px += 2 * margin;
  canvas.axis_u_px += margin, canvas.tip_v_px += margin;
  std::vector<double> img = Coverage(tool, canvas, turn_rad, blur_rad, f.drops, rng);
  for (double& x : img) x = c.bright - (c.bright - c.dark) * x;
  grey_image::GaussianBlur(&img, canvas.width_px, canvas.height_px, c.psf_sigma_px);
  img = Resample(img, c, margin);
  std::normal_distribution<double> noise(0, c.noise_sigma);
  f.pixels.resize(img.size());
  for (size_t i = 0; i < img.size(); ++i)
    f.pixels[i] = static_cast<std::uint8_t>(
        std::clamp(std::lround(img[i] + (c.noise_sigma > 0 ? noise(rng) : 0.0)), 0L, 255L));
  return f;
}

void WritePgm(const std::string& path, int w, int h, const std::vector<std::uint8_t>& px) {
  try {
    grey_image::WritePgm(path, w, h, px);
  } catch (const std::runtime_error& e) {
    Fail(e.what());
  }
}

int RenderToolSequence(const ToolDescription& tool,
                       const ToolCameraModel& c,
                       const StrobePlan& plan,
                       double start_turn_rad,
                       unsigned seed,
                       const std::string& dir,
                       const SpindleShift& shift,
                       double drift_across_mm) {
  std::filesystem::create_directories(dir);
  ToolCameraModel drawn = c;  // where the spindle really stands
  drawn.axis_u_px += drift_across_mm / c.mm_per_px;
  if (c.glass_side_y_mm) *drawn.glass_side_y_mm -= drift_across_mm;  // the block stays put
  std::mt19937 rng(seed);
  const double blur = plan.pulse_width_us * 1e-6 * plan.rpm / 60 * 2 * M_PI;
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  std::vector<std::string> files;
  for (size_t i = 0; i < plan.position.size(); ++i) {
    const double turn = start_turn_rad + 2 * M_PI * plan.position[i] / plan.positions;
    const ToolFrame f = RenderToolFrame(tool, drawn, turn, blur, rng);
    char name[32];
    std::snprintf(name, sizeof name, "frame_%04zu.pgm", i);
    WritePgm((std::filesystem::path(dir) / name).string(), c.width_px, c.height_px, f.pixels);
    files.emplace_back(name);
    nlohmann::ordered_json drops = nlohmann::ordered_json::array();
    for (const Drop& d : f.drops) drops.push_back({d.y_mm, d.h_mm, d.radius_mm});
    frames.push_back({{"file", name},
                      {"position", plan.position[i]},
                      {"turn_deg", std::fmod(turn * base::kDegPerRad, 360.0)},
                      {"drops_y_h_r_mm", drops}});
  }
  nlohmann::ordered_json edges = nlohmann::ordered_json::array();
  for (int k = 0; k < tool.flutes; ++k) {
    nlohmann::ordered_json defects = nlohmann::ordered_json::array();
    for (const EdgeDefect& d : tool.edges[static_cast<size_t>(k)].defects)
      defects.push_back({{"h_mm", d.h_mm}, {"length_mm", d.length_mm}, {"depth_mm", d.depth_mm}});
    edges.push_back(
        {{"radius_mm", tool.Radius() + tool.edges[static_cast<size_t>(k)].radial_offset_mm},
         {"tip_h_mm", tool.TipH(k)},
         {"defects", defects}});
  }
  const nlohmann::ordered_json truth = {
      {"format", "mlprobe-tool-frames/1"},
      {"tool", tool.id},
      {"camera", CameraJson(drawn)},
      {"drift_across_mm", drift_across_mm},
      {"strobe",
       {{"rpm", plan.rpm}, {"positions", plan.positions}, {"pulse_width_us", plan.pulse_width_us}}},
      {"start_turn_deg", start_turn_rad * base::kDegPerRad},
      {"edges", edges},
      {"frames", frames}};
  base::WriteFileAtomically((std::filesystem::path(dir) / "truth.json").string(),
                            truth.dump(1) + "\n");
  // What a real tool camera records beside its images (no truth): the measurement's input.
  base::WriteFileAtomically((std::filesystem::path(dir) / "images.json").string(),
                            ToolImagesJson(c, plan, shift, files, plan.position));
  return static_cast<int>(plan.position.size());
}

}  // namespace mlp::toolcam
