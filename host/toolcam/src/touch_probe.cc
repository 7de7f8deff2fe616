#include "mlp/toolcam/touch_probe.h"

#include "mlp/geometry/columns.h"
#include "mlp/geometry/contour.h"
#include "mlp/geometry/fit.h"
#include "mlp/toolcam/measure.h"

#include <cmath>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

// The side face is taken this far outside the idle ball: a lateral pretravel up to it.
constexpr double kLateralClearMm = 0.05;

[[noreturn]] void Fail(const std::string& what) { throw ToolError("touch probe: " + what); }

void CheckStylus(const ToolDescription& s) {
  if (!s.stylus) throw ToolInputError("touch probe: the description is not a stylus");
}

void CheckFrames(const std::vector<std::vector<std::uint8_t>>& frames, const ToolCameraModel& c) {
  if (frames.empty()) throw ToolInputError("touch probe: no frames");
  for (const auto& f : frames)
    if (f.size() != static_cast<size_t>(c.width_px) * static_cast<size_t>(c.height_px))
      throw ToolInputError("touch probe: a frame's size is not the camera's");
}

// Every frame's iso-grey outline in the tool frame (y, h) where `keep` says so.
template <typename Keep>
std::vector<Vec2> OutlineWhere(const std::vector<std::vector<std::uint8_t>>& frames,
                               const ToolCameraModel& c,
                               Keep keep) {
  std::vector<Vec2> kept;
  for (const auto& f : frames) {
    const geometry::GreyView g{f.data(), c.width_px, c.height_px};
    const geometry::Points2 iso = geometry::AllCrossings(g, ShadowLevel(f));
    for (Eigen::Index i = 0; i < iso.cols(); ++i)
      if (const Vec2 p = ToolFromImage(iso.col(i), c); keep(p)) kept.push_back(p);
  }
  return kept;
}

}  // namespace

StylusSeen MeasureStylus(const std::vector<std::vector<std::uint8_t>>& frames,
                         const ToolCameraModel& c,
                         const ToolDescription& stylus) {
  CheckStylus(stylus);
  CheckFrames(frames, c);
  // The ball below where the stem joins it (its outline is the ball's alone there), with room
  // for the ball standing 0.2 mm off its nominal place.
  const double r = stylus.Radius(), rs = stylus.stem_diameter_mm / 2;
  const double top_h = r + 0.5 * std::sqrt(r * r - rs * rs);
  const std::vector<Vec2> kept = OutlineWhere(frames, c, [&](const Vec2& p) {
    return p.y() < top_h && p.y() > -0.2 && std::abs(p.x()) < r + 0.2;
  });
  if (kept.size() < 50) Fail("the frames do not show the stylus' ball");
  const auto fit = geometry::FitCircle2(geometry::AsColumns(kept));
  StylusSeen s;
  s.centre_y_mm = fit.shape.center.x(), s.centre_h_mm = fit.shape.center.y();
  s.radius_mm = fit.shape.radius, s.rms_mm = fit.stats.rms,
  s.points = static_cast<int>(kept.size());
  return s;
}

double MeasureGlassFace(const std::vector<std::vector<std::uint8_t>>& frames,
                        const ToolCameraModel& c,
                        const ToolDescription& stylus,
                        double clear_mm) {
  CheckStylus(stylus);
  CheckFrames(frames, c);
  std::vector<Vec2> kept;
  std::vector<std::uint8_t> inverted;
  for (const auto& f : frames) {
    // The face is each column's first fall from the light: the first rise of the negative.
    inverted.resize(f.size());
    for (size_t i = 0; i < f.size(); ++i) inverted[i] = static_cast<std::uint8_t>(255 - f[i]);
    const geometry::GreyView g{inverted.data(), c.width_px, c.height_px};
    const double level = ShadowLevel(inverted);
    const geometry::Points2 cols = geometry::ColumnCrossings(g, level);
    for (Eigen::Index i = 0; i < cols.cols(); ++i) {
      if (g.At(static_cast<int>(cols(0, i)), 0) >= level) continue;  // starts in the shadow
      const Vec2 p = ToolFromImage(cols.col(i), c);
      if (std::abs(p.x()) > stylus.Radius() + clear_mm) kept.push_back(p);
    }
  }
  if (kept.size() < 20) Fail("the frames do not show the glass block's face beside the stylus");
  const auto line = geometry::FitLine2(geometry::AsColumns(kept)).shape;
  // The line through `point` along `direction`, met with y = 0.
  if (std::abs(line.direction.x()) < 0.5) Fail("the glass block's face is not across the view");
  return line.point.y() - line.point.x() * line.direction.y() / line.direction.x();
}

TriggerCalibration CalibrateTrigger(const std::vector<std::vector<std::uint8_t>>& idle,
                                    const ToolCameraModel& idle_camera,
                                    const std::vector<std::vector<std::uint8_t>>& trigger,
                                    const ToolCameraModel& trigger_camera,
                                    const ToolDescription& stylus) {
  TriggerCalibration t;
  t.idle = MeasureStylus(idle, idle_camera, stylus);
  t.face_h_mm = MeasureGlassFace(trigger, trigger_camera, stylus);
  const double bottom_h = t.idle.centre_h_mm - t.idle.radius_mm;
  t.pretravel_mm = t.face_h_mm - bottom_h;
  if (!(t.pretravel_mm >= 0 && t.pretravel_mm <= 1.0))
    Fail("a pretravel of " + std::to_string(t.pretravel_mm) +
         " mm: the frames are not of one probe, or the face is not the one it touched");
  t.idle_length_mm = stylus.length_mm - bottom_h;
  t.trigger_length_mm = stylus.length_mm - t.face_h_mm;
  t.ball_diameter_mm = 2 * t.idle.radius_mm;
  return t;
}

double MeasureGlassSide(const std::vector<std::vector<std::uint8_t>>& frames,
                        const ToolCameraModel& c,
                        const ToolDescription& stylus,
                        const StylusSeen& idle,
                        double clear_mm) {
  CheckStylus(stylus);
  CheckFrames(frames, c);
  // Farther from the idle ball's centre than its radius by `clear_mm` (the ball, pushed back by
  // the pretravel, stays inside that) and beyond the stem: only the face's edge is left.
  const Vec2 centre(idle.centre_y_mm, idle.centre_h_mm);
  const double reach = idle.radius_mm + clear_mm, stem = stylus.stem_diameter_mm / 2 + clear_mm;
  const std::vector<Vec2> kept = OutlineWhere(frames, c, [&](const Vec2& p) {
    return (p - centre).norm() > reach && std::abs(p.x() - centre.x()) > stem;
  });
  if (kept.size() < 20) Fail("the frames do not show the glass block's side face");
  const auto line = geometry::FitLine2(geometry::AsColumns(kept)).shape;
  if (std::abs(line.direction.y()) < 0.99)
    Fail("the glass block's side face does not stand along the spindle axis");
  return line.point.x() + (centre.y() - line.point.y()) * line.direction.x() / line.direction.y();
}

LateralTrigger CalibrateLateralTrigger(const StylusSeen& idle,
                                       const std::vector<std::vector<std::uint8_t>>& trigger,
                                       const ToolCameraModel& trigger_camera,
                                       const ToolDescription& stylus) {
  LateralTrigger t;
  t.face_y_mm = MeasureGlassSide(trigger, trigger_camera, stylus, idle, kLateralClearMm);
  t.side = t.face_y_mm >= idle.centre_y_mm ? 1 : -1;
  t.effective_radius_mm = t.side * (t.face_y_mm - idle.centre_y_mm);
  t.pretravel_mm = idle.radius_mm - t.effective_radius_mm;
  if (!(t.pretravel_mm >= 0 && t.pretravel_mm <= kLateralClearMm))
    Fail("a lateral pretravel of " + std::to_string(t.pretravel_mm) +
         " mm: the frames are not of one probe, or the face is not the one it touched");
  return t;
}

double EffectiveDiameter(const std::vector<LateralTrigger>& sides) {
  if (sides.empty() || sides.size() > 2)
    throw ToolInputError("touch probe: the effective diameter takes one or two side faces");
  if (sides.size() == 1) return 2 * sides[0].effective_radius_mm;
  if (sides[0].side == sides[1].side)
    throw ToolInputError("touch probe: both side faces are on the same side of the ball");
  return std::abs(sides[0].face_y_mm - sides[1].face_y_mm);
}

}  // namespace mlp::toolcam
