#include "mlp/toolcam/pin_calibration.h"

#include "mlp/base/json_fields.h"
#include "mlp/base/units.h"
#include "mlp/geometry/contour.h"
#include "mlp/toolcam/measure.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "camera_json.h"
#include <Eigen/Dense>
#include <nlohmann/json.hpp>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

[[noreturn]] void Fail(const std::string& what) { throw ToolError("pin calibration: " + what); }
[[noreturn]] void Bad(const std::string& what) { throw ToolInputError("pin calibration: " + what); }

constexpr double kBladeMarginMm = 0.08;  // blade rows keep this far from both ends' blur
constexpr double kTipShare = 0.3;        // a blade's end: the columns this share of its width
constexpr int kMinBladeImages = 8;       // from its middle, either way
// k1's standard error to count as measured: 0.006 px at the corner of a 1024 x 768 image, a
// 750 px wide pin's width to 4 ppm.
constexpr double kDistortionSigmaMax = 1e-5;

// An image's flanks, paired by row (undistorted pixels), and the row of the pin's end.
struct Flanks {
  std::vector<Vec2> left, right;
  double end_v = 0;
};

// The end's row: the columns between the flanks rise into the light there, the blades'
// columns lower down at their own ends: the upper cluster of the crossings is the end.
double EndRow(std::vector<double> v) {
  if (v.size() < 10) Fail("an image does not show the pin's end");
  std::sort(v.begin(), v.end());
  const double upper = v[v.size() / 4] + 6.0;
  std::vector<double> end;
  for (double x : v)
    if (x <= upper) end.push_back(x);
  return end[end.size() / 2];
}

Flanks FindFlanks(const geometry::GreyView& g, double level, const ToolCameraModel& c) {
  // Both flanks per row: the first fall from the light (left), the first rise (right).
  const geometry::Points2 left = geometry::RowCrossings(g, level, true);
  const geometry::Points2 right = geometry::RowCrossings(g, level, false);
  std::map<int, Vec2> left_at;
  for (Eigen::Index i = 0; i < left.cols(); ++i)
    left_at[static_cast<int>(left(1, i))] = c.Undistort(left.col(i));
  Flanks f;
  for (Eigen::Index i = 0; i < right.cols(); ++i) {
    const auto it = left_at.find(static_cast<int>(right(1, i)));
    if (it == left_at.end()) continue;
    f.left.push_back(it->second), f.right.push_back(c.Undistort(right.col(i)));
  }
  if (f.left.size() < 50) Fail("an image shows both of the pin's flanks on fewer than 50 rows");
  double lo_u = 1e300, hi_u = -1e300;
  for (size_t k = 0; k < f.left.size(); ++k)
    lo_u = std::min(lo_u, f.left[k].x()), hi_u = std::max(hi_u, f.right[k].x());
  const geometry::Points2 cols = geometry::ColumnCrossings(g, level);
  std::vector<double> end_v;
  const double inset = 0.15 * (hi_u - lo_u);  // away from the end's rounded edge
  for (Eigen::Index i = 0; i < cols.cols(); ++i)
    if (cols(0, i) > lo_u + inset && cols(0, i) < hi_u - inset &&
        g.At(static_cast<int>(cols(0, i)), 0) < level)
      end_v.push_back(c.Undistort(cols.col(i)).y());
  f.end_v = EndRow(end_v);
  return f;
}

// One blade in one image, in the tool frame of the first pass' camera [mm].
struct BladeSeen {
  double y = 0, end_h = 0;
  double chord = 0;  ///< mean of sqrt(1 - (dy / r)^2) over the end's columns (a pitch's share)
};

// The dark runs across row v at least `min_px` long: [first, last] columns.
std::vector<std::pair<int, int>> DarkRuns(const geometry::GreyView& g,
                                          int v,
                                          double level,
                                          double min_px) {
  std::vector<std::pair<int, int>> runs;
  for (int u = 0; u < g.width;) {
    if (g.At(u, v) >= level) {
      ++u;
      continue;
    }
    int end = u;
    while (end + 1 < g.width && g.At(end + 1, v) < level) ++end;
    if (end - u + 1 >= min_px) runs.emplace_back(u, end);
    u = end + 1;
  }
  return runs;
}

// The blade in columns [u0, u1) between rows [v_top, v_bot]: its middle over the rows, then
// its end below them. False when it does not show as one rod with an end.
bool MeasureBlade(const geometry::GreyView& g,
                  double level,
                  const ToolCameraModel& cam,
                  int u0,
                  int u1,
                  int v_top,
                  int v_bot,
                  double band_lo_h,
                  double band_hi_h,
                  double radius_mm,
                  BladeSeen* out) {
  const geometry::GreyView rows = g.Window(u0, v_top, u1 - u0, v_bot - v_top + 1);
  const geometry::Points2 l = geometry::RowCrossings(rows, level, true);
  const geometry::Points2 r = geometry::RowCrossings(rows, level, false);
  std::map<int, double> left_u;
  for (Eigen::Index i = 0; i < l.cols(); ++i) left_u[static_cast<int>(l(1, i))] = l(0, i);
  double sum_y = 0, sum_u = 0;
  int n = 0;
  for (Eigen::Index i = 0; i < r.cols(); ++i) {
    const auto it = left_u.find(static_cast<int>(r(1, i)));
    if (it == left_u.end()) continue;
    const Vec2 mid((it->second + r(0, i)) / 2 + u0, r(1, i) + v_top);
    const Vec2 yh = cam.ToolFromPixel(cam.Undistort(mid));
    if (yh.y() < band_lo_h || yh.y() > band_hi_h) continue;
    sum_y += yh.x(), sum_u += mid.x(), ++n;
  }
  if (n < 20) return false;
  out->y = sum_y / n;
  const double half_px = kTipShare * radius_mm * 2 / cam.mm_per_px, centre_u = sum_u / n;
  const int c0 = std::max(0, static_cast<int>(std::floor(centre_u - half_px)));
  const int top = std::max(0, v_bot - 10);
  const geometry::GreyView below =
      g.Window(c0, top, static_cast<int>(std::ceil(centre_u + half_px)) - c0 + 1, g.height - top);
  const geometry::Points2 ends = geometry::ColumnCrossings(below, level);
  double sum_h = 0, sum_chord = 0;
  int m = 0;
  for (Eigen::Index i = 0; i < ends.cols(); ++i) {
    const Vec2 yh = cam.ToolFromPixel(cam.Undistort(Vec2(ends(0, i) + c0, ends(1, i) + top)));
    const double d = (yh.x() - out->y) / radius_mm;
    if (std::abs(d) > 2 * kTipShare) continue;
    sum_h += yh.y(), sum_chord += std::sqrt(1 - d * d), ++m;
  }
  if (m < 10) return false;
  out->end_h = sum_h / m, out->chord = sum_chord / m;
  return true;
}

// Both blades in an image, [0] the longer; false when they do not stand apart.
bool FindBlades(const geometry::GreyView& g,
                double level,
                const ToolCameraModel& cam,
                const ToolDescription& pin,
                BladeSeen seen[2]) {
  const auto& b = pin.blades;
  const double shorter = std::min(b[0].extends_mm, b[1].extends_mm);
  const double width = std::min(b[0].width_mm, b[1].width_mm);
  const double band_hi = -kBladeMarginMm, band_lo = -shorter + kBladeMarginMm;
  const int v_top = static_cast<int>(std::ceil(cam.PixelFromTool({0, band_hi}).y()));
  const int v_bot = static_cast<int>(std::floor(cam.PixelFromTool({0, band_lo}).y()));
  if (v_top < 0 || v_bot >= g.height || v_bot - v_top < 20)
    Fail("the blades are not in the image (the pin's end too low or the blades too short)");
  const auto runs = DarkRuns(g, (v_top + v_bot) / 2, level, 0.5 * width / cam.mm_per_px);
  if (runs.size() != 2 || runs[1].first - runs[0].second < 4) return false;
  const int split = (runs[0].second + runs[1].first) / 2;
  BladeSeen left, right;
  if (!MeasureBlade(g, level, cam, 0, split, v_top, v_bot, band_lo, band_hi, width / 2, &left) ||
      !MeasureBlade(g, level, cam, split, g.width, v_top, v_bot, band_lo, band_hi, width / 2,
                    &right))
    return false;
  const bool left_longer = left.end_h < right.end_h;  // the longer blade's end is lower
  seen[0] = left_longer ? left : right, seen[1] = left_longer ? right : left;
  return true;
}

// Each blade's depth in each image from the turn of its y: y = A sin a + B cos a + C over the
// images' angles a, and x = dy/da = A cos a - B sin a (pin_calibration.h). Throws when the
// blade's y does not go round the circle of its offset.
std::vector<double> Depths(const std::vector<double>& angle,
                           const std::vector<double>& y,
                           double offset_mm,
                           int blade) {
  const auto n = static_cast<Eigen::Index>(angle.size());
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = angle[static_cast<size_t>(i)];
    a.row(i) << std::sin(t), std::cos(t), 1;
    b(i) = y[static_cast<size_t>(i)];
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  const double amplitude = std::hypot(s(0), s(1));
  if (!(std::abs(amplitude - std::abs(offset_mm)) < 0.05 * std::abs(offset_mm) + 0.01))
    Fail("blade " + std::to_string(blade + 1) + " goes round " + std::to_string(amplitude) +
         " mm off the axis, not its " + std::to_string(std::abs(offset_mm)) +
         " mm: wrong pin file, or the positions are not the images' angles");
  std::vector<double> x;
  x.reserve(angle.size());
  for (double t : angle) x.push_back(s(0) * std::cos(t) - s(1) * std::sin(t));
  return x;
}

void CheckPinInput(const std::vector<std::vector<std::uint8_t>>& frames,
                   const std::vector<int>& positions,
                   int position_count,
                   const ToolDescription& pin) {
  if (!pin.pin) Bad("the calibration needs a pin (\"kind\": \"pin\")");
  if (frames.empty() || frames.size() != positions.size() || position_count < 1)
    Bad("each image needs its angular position");
  if (pin.blades.size() == 2 &&
      std::abs(pin.blades[0].extends_mm - pin.blades[1].extends_mm) < 0.05)
    Bad("the blades must differ in length by 0.05 mm or more (which is which)");
}

// The flank rows above the pin's end, paired (as FindFlankRows keeps them).
template <class Visit>
void FlankRowsAboveEnd(const Flanks& f,
                       const ToolCameraModel& c,
                       const ToolDescription& pin,
                       Visit visit) {
  // Flank rows stop above the end's edge round and its blur, allowing for a roll of 1 deg
  // across the pin (its corner a flank's width x 0.02 higher on one side): rows in the
  // round's blur on one flank only bent the axis (2 millidegrees over 200 rows).
  const double margin_px =
      pin.corner_radius_mm / c.mm_per_px + 20 + 0.01 * (f.right.front().x() - f.left.front().x());
  for (size_t k = 0; k < f.left.size(); ++k)
    if (f.left[k].y() <= f.end_v - margin_px) visit(f.left[k], f.right[k]);
}

// The lens' radial distortion from the flanks' straightness. In distorted pixels a straight
// flank u = a + b v (ideal) reads u = a + b v + k1 rho^2 (u - cx) to first order (Undistort's
// model; the b k1 rho^2 (v - cy) term dropped: b is the roll, under 0.02): linear in both
// flanks' (a, b) and k1. Then once more with the exact model about the first estimate. The
// flanks must span a quarter of the image's height and determine k1 to kDistortionSigmaMax,
// else `c`'s value stands (false): the curvature k1 puts in a flank grows with the square of
// its rows' distance from the centre, so a pin shown over most of the height, in a few dozen
// images, measures it; three images of a pin ending mid-image do not (1e-4).
bool DistortionFromFlanks(const std::vector<std::vector<std::uint8_t>>& frames,
                          const ToolCameraModel& c,
                          const ToolDescription& pin,
                          double* k1,
                          double* sigma) {
  *sigma = std::nan("");
  ToolCameraModel raw = c;
  raw.distortion_k1 = 0;
  std::vector<Vec2> left, right;
  for (const auto& px : frames) {
    const geometry::GreyView g{px.data(), c.width_px, c.height_px};
    const Flanks f = FindFlanks(g, ShadowLevel(px), raw);
    FlankRowsAboveEnd(f, raw, pin,
                      [&](const Vec2& l, const Vec2& r) { left.push_back(l), right.push_back(r); });
  }
  double v_lo = 1e300, v_hi = -1e300;
  for (const Vec2& p : left) v_lo = std::min(v_lo, p.y()), v_hi = std::max(v_hi, p.y());
  if (left.size() < 100 || v_hi - v_lo < c.height_px / 4.0) return false;
  // About the lens' centre, its tangential terms (given, as the principal point) taken out:
  // raw's k1 is 0.
  for (auto* side : {&left, &right})
    for (Vec2& p : *side) p = raw.Undistort(p);
  const double cx = raw.LensCentre().x(), cy = raw.LensCentre().y(), corner2 = c.Corner2();
  double k = 0;
  for (int round = 0; round < 2; ++round) {
    const auto n = static_cast<Eigen::Index>(left.size());
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * n, 5);
    Eigen::VectorXd obs(2 * n);
    for (Eigen::Index side = 0; side < 2; ++side)
      for (Eigen::Index i = 0; i < n; ++i) {
        const Vec2& p = (side == 0 ? left : right)[static_cast<size_t>(i)];
        const Vec2 d(p.x() - cx, p.y() - cy);
        const double rho2 = d.squaredNorm() / corner2;
        // About the estimate so far: the ideal point with k, and its change with k.
        const Vec2 ideal = Vec2(cx, cy) + d / (1 + k * rho2);
        const Eigen::Index row = side * n + i;
        a(row, 2 * side) = 1, a(row, 2 * side + 1) = ideal.y();
        a(row, 4) = rho2 * (p.x() - cx);
        obs(row) = ideal.x() + k * rho2 * (p.x() - cx);
      }
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(obs);
    k = x(4);
    // Its standard error from the residuals' scatter (each row's own noise: a lower bound, as
    // the sub-pixel detector's error repeats along an edge).
    const double var = (obs - a * x).squaredNorm() / static_cast<double>(2 * n - 5);
    *sigma = std::sqrt(var * (a.transpose() * a).inverse()(4, 4));
  }
  if (!std::isfinite(k) || !(*sigma <= kDistortionSigmaMax)) return false;
  *k1 = k;
  return true;
}

// Pass 1's findings over every image: the flank rows above the pin's end (width, middle), the
// end's row per image, and each image's view and shadow level for pass 2.
struct FlankRows {
  std::vector<double> width, mid_u, mid_v, ends;
  std::vector<geometry::GreyView> views;
  std::vector<double> levels;
};

FlankRows FindFlankRows(const std::vector<std::vector<std::uint8_t>>& frames,
                        const ToolCameraModel& c,
                        const ToolDescription& pin) {
  FlankRows r;
  for (const auto& px : frames) {
    if (px.size() != static_cast<size_t>(c.width_px) * static_cast<size_t>(c.height_px))
      Bad("an image's size is not the camera's");
    r.views.push_back({px.data(), c.width_px, c.height_px});
    r.levels.push_back(ShadowLevel(px));
    const Flanks f = FindFlanks(r.views.back(), r.levels.back(), c);
    r.ends.push_back(f.end_v);
    FlankRowsAboveEnd(f, c, pin, [&](const Vec2& l, const Vec2& rt) {
      r.width.push_back(rt.x() - l.x());
      r.mid_u.push_back((l.x() + rt.x()) / 2), r.mid_v.push_back(l.y());
    });
  }
  if (r.width.size() < 50) Fail("too few flank rows above the pin's end");
  return r;
}

// The scale from the flanks' width, the roll from their middle line u = a + b v (least
// squares); returns the camera with the pin's end as the tip, pitch not yet known.
ToolCameraModel ScaleAndRoll(const FlankRows& rows,
                             const ToolCameraModel& c,
                             const ToolDescription& pin,
                             PinCalibration* p) {
  p->rows = static_cast<int>(rows.width.size());
  const Eigen::Map<const Eigen::VectorXd> w(rows.width.data(),
                                            static_cast<Eigen::Index>(rows.width.size()));
  p->width_rms_px = std::sqrt((w.array() - w.mean()).square().mean());
  Eigen::MatrixXd a(static_cast<Eigen::Index>(rows.mid_u.size()), 2);
  Eigen::VectorXd u(static_cast<Eigen::Index>(rows.mid_u.size()));
  for (size_t k = 0; k < rows.mid_u.size(); ++k)
    a.row(static_cast<Eigen::Index>(k)) << 1, rows.mid_v[k],
        u(static_cast<Eigen::Index>(k)) = rows.mid_u[k];
  const Eigen::Vector2d line = a.colPivHouseholderQr().solve(u);
  const double end_v = Eigen::Map<const Eigen::VectorXd>(
                           rows.ends.data(), static_cast<Eigen::Index>(rows.ends.size()))
                           .mean();
  p->roll_deg = std::atan(line(1)) * base::kDegPerRad;
  // The flanks' distance along a row is the diameter over cos(roll).
  p->mm_per_px = pin.diameter_mm / (std::cos(std::atan(line(1))) * w.mean());
  ToolCameraModel first = c;  // the pin's end as the tip
  first.mm_per_px = p->mm_per_px, first.roll_deg = p->roll_deg, first.pitch_deg = 0;
  first.axis_u_px = line(0) + line(1) * end_v, first.tip_v_px = end_v;
  return first;
}

// Pass 2: the blades' ends against their depths: tan(pitch) and the pin end's height in the
// first pass' frame [mm], returned.
double PitchFromBlades(const FlankRows& rows,
                       const std::vector<int>& positions,
                       int position_count,
                       const ToolCameraModel& first,
                       const ToolDescription& pin,
                       PinCalibration* p) {
  std::vector<double> angle, y[2], h[2], chord[2];
  for (size_t i = 0; i < rows.views.size(); ++i) {
    BladeSeen seen[2];
    if (!FindBlades(rows.views[i], rows.levels[i], first, pin, seen)) continue;
    angle.push_back(2 * M_PI * positions[i] / position_count);
    for (int k = 0; k < 2; ++k)
      y[k].push_back(seen[k].y), h[k].push_back(seen[k].end_h), chord[k].push_back(seen[k].chord);
  }
  p->blade_images = static_cast<int>(angle.size());
  if (p->blade_images < kMinBladeImages)
    Fail("the blades stood apart in " + std::to_string(p->blade_images) + " images, " +
         std::to_string(kMinBladeImages) + " are needed (images round the whole turn)");
  const int longer = pin.blades[0].extends_mm > pin.blades[1].extends_mm ? 0 : 1;
  const PinBlade* blade[2] = {&pin.blades[static_cast<size_t>(longer)],
                              &pin.blades[static_cast<size_t>(1 - longer)]};
  std::vector<double> x[2];
  for (int k = 0; k < 2; ++k) x[k] = Depths(angle, y[k], blade[k]->offset_mm, k);
  // end_h_seen + extends + chord r |t| = end_h - x t (the rod's round end shows lower by its
  // chord's depth times |t|): linear in (end_h, t) once |t| is known; three rounds.
  const auto n = static_cast<Eigen::Index>(2 * angle.size());
  double t = 0, end_h = 0;
  Eigen::VectorXd resid;
  for (int round = 0; round < 3; ++round) {
    Eigen::MatrixXd m(n, 2);
    Eigen::VectorXd obs(n);
    for (int k = 0; k < 2; ++k)
      for (size_t i = 0; i < angle.size(); ++i) {
        const auto row = static_cast<Eigen::Index>(k * angle.size() + i);
        m.row(row) << 1, -x[k][i];
        obs(row) =
            h[k][i] + blade[k]->extends_mm + chord[k][i] * blade[k]->width_mm / 2 * std::abs(t);
      }
    const Eigen::Vector2d s = m.colPivHouseholderQr().solve(obs);
    end_h = s(0), t = s(1);
    resid = obs - m * s;
  }
  p->pitch_deg = std::atan(t) * base::kDegPerRad;
  p->pitch_measured = true;
  p->blade_rms_um = std::sqrt(resid.squaredNorm() / static_cast<double>(n)) * 1e3;
  return end_h;
}

}  // namespace

FrameLoop PinCalibration::Loop(double length_mm, double shift_y_mm, double shift_z_mm) const {
  // The detector sees the gauge point (the chuck's origin, the structure's with the encoders at
  // the calibration's place) at its pixel, the spindle axis turned by the roll.
  geometry::Pose3 detector_from_structure = geometry::Pose3::Identity();
  detector_from_structure.linear() =
      Eigen::AngleAxisd(roll_deg / base::kDegPerRad, geometry::Vec3::UnitX()).toRotationMatrix();
  detector_from_structure.translation() =
      geometry::Vec3(0, gauge_u_px * mm_per_px, -gauge_v_px * mm_per_px);
  FrameLoop loop;
  loop.structure_from_detector = detector_from_structure.inverse();
  loop.tool_length_mm = length_mm;
  loop.encoder_y_mm = shift_y_mm, loop.encoder_z_mm = shift_z_mm;
  return loop;
}

ToolCameraModel PinCalibration::CameraFor(const ToolCameraModel& base,
                                          double length_mm,
                                          double shift_y_mm,
                                          double shift_z_mm) const {
  ToolCameraModel c = base;
  c.mm_per_px = mm_per_px, c.pitch_deg = pitch_deg;
  return CameraThroughLoop(Loop(length_mm, shift_y_mm, shift_z_mm), c);
}

std::string CameraCalibrationJson(const PinCalibration& p,
                                  const ToolCameraModel& base,
                                  const std::string& pin_id) {
  nlohmann::ordered_json j = {{"format", "mlprobe-tool-camera/1"},
                              {"pin", pin_id},
                              {"width_px", base.width_px},
                              {"height_px", base.height_px},
                              {"distortion_k1", p.distortion_k1},
                              {"distortion_measured", p.distortion_measured},
                              {"mm_per_px", p.mm_per_px},
                              {"roll_deg", p.roll_deg},
                              {"pitch_deg", p.pitch_deg},
                              {"pitch_measured", p.pitch_measured},
                              {"gauge_u_px", p.gauge_u_px},
                              {"gauge_v_px", p.gauge_v_px},
                              {"end_u_px", p.end_u_px},
                              {"end_v_px", p.end_v_px},
                              {"width_rms_px", p.width_rms_px},
                              {"blade_rms_um", p.blade_rms_um},
                              {"rows", p.rows},
                              {"blade_images", p.blade_images}};
  AddLensJson(base, &j);
  return j.dump(1) + "\n";
}

PinCalibration ParseCameraCalibration(const std::string& text,
                                      ToolCameraModel* base,
                                      const std::string& where) {
  namespace jf = base::json_fields;
  const auto j = jf::ParseDocument<ToolInputError>(text, "mlprobe-tool-camera/1", where);
  const std::string& w = where;
  base->width_px = jf::Integer<ToolInputError>(j, "width_px", w);
  base->height_px = jf::Integer<ToolInputError>(j, "height_px", w);
  ReadLensJson(j, w, base);
  PinCalibration p;
  p.mm_per_px = jf::Number<ToolInputError>(j, "mm_per_px", w);
  p.roll_deg = jf::Number<ToolInputError>(j, "roll_deg", w);
  p.pitch_deg = jf::NumberOr<ToolInputError>(j, "pitch_deg", 0.0, w);
  p.pitch_measured = jf::FlagOr<ToolInputError>(j, "pitch_measured", false, w);
  p.gauge_u_px = jf::Number<ToolInputError>(j, "gauge_u_px", w);
  p.gauge_v_px = jf::Number<ToolInputError>(j, "gauge_v_px", w);
  p.end_u_px = jf::NumberOr<ToolInputError>(j, "end_u_px", 0.0, w);
  p.end_v_px = jf::NumberOr<ToolInputError>(j, "end_v_px", 0.0, w);
  p.distortion_k1 = base->distortion_k1;
  p.distortion_measured = jf::FlagOr<ToolInputError>(j, "distortion_measured", false, w);
  ToolCameraModel check = p.CameraFor(*base, 0.0);
  check.Validate();  // the scale, the tilts and the size in range
  return p;
}

PinCalibration CalibrateWithPin(const std::vector<std::vector<std::uint8_t>>& frames,
                                const std::vector<int>& positions,
                                int position_count,
                                const ToolCameraModel& c,
                                const ToolDescription& pin) {
  CheckPinInput(frames, positions, position_count, pin);
  PinCalibration p;
  ToolCameraModel lens = c;  // the lens' distortion measured first: everything else uses it
  p.distortion_measured =
      DistortionFromFlanks(frames, c, pin, &lens.distortion_k1, &p.distortion_sigma);
  p.distortion_k1 = lens.distortion_k1;
  const FlankRows rows = FindFlankRows(frames, lens, pin);
  const ToolCameraModel first = ScaleAndRoll(rows, lens, pin, &p);
  const double end_h = pin.blades.size() == 2
                           ? PitchFromBlades(rows, positions, position_count, first, pin, &p)
                           : 0.0;  // the pin's end in the first pass' frame
  const Vec2 end = first.PixelFromTool({0, end_h});
  const Vec2 gauge = first.PixelFromTool({0, end_h + pin.length_mm});
  p.end_u_px = end.x(), p.end_v_px = end.y();
  p.gauge_u_px = gauge.x(), p.gauge_v_px = gauge.y();
  return p;
}

}  // namespace mlp::toolcam
