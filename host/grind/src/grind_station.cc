#include "mlp/grind/grind_station.h"

#include <cmath>

namespace mlp::grind {

using geometry::Vec2;

namespace {
constexpr double kSamePlaceMm = 0.0005;  // a centre within this of the last is the same stroke
}  // namespace

void GrindStationConfig::Validate() const {
  job.camera.Validate();
  job.bevel.Validate();
  trigger.Validate();
  if (!(job.wheel_radius_mm > 0) || !(job.limit_mm > 0) || !(job.stock_mm >= 0))
    throw GrindInputError("grind station: wheel radius and limit > 0, stock >= 0");
  if (!(wear_mm >= 0 && wear_mm < 0.5 * job.wheel_radius_mm))
    throw GrindInputError("grind station: wear must be 0..half the wheel's radius");
  if (!machine_error_mm.allFinite() || !std::isfinite(work_top_mm))
    throw GrindInputError("grind station: the machine's error and the work's top must be finite");
  if (!(max_compensation_mm > 0))
    throw GrindInputError("grind station: max_compensation_mm must be > 0");
  if (!(trigger.clear_mm > work_top_mm))
    throw GrindInputError("grind station: the trigger's clear height must be above the work");
}

GrindStation::GrindStation(const GrindStationConfig& config, unsigned seed)
    : cfg_((config.Validate(), config)),
      nominal_(config.job.profile),
      trigger_(config.trigger),
      seed_(seed) {
  last_frame_ =
      RenderGrindFrame(nominal_, cfg_.job.stock_mm, {}, cfg_.job.camera, seed_++, cfg_.job.bevel);
}

void GrindStation::Cut(const Vec2& slide_mm, const Vec2& nc_c_mm) {
  if (!cut_c_ || (*cut_c_ - nc_c_mm).norm() > kSamePlaceMm) {  // a new cutting point
    cut_c_ = nc_c_mm;
    before_ = last_frame_;
  }
  const Vec2 real = slide_mm + cfg_.machine_error_mm;
  if (strokes_.empty() || (strokes_.back().center_mm - real).norm() > kSamePlaceMm)
    strokes_.push_back({real, cfg_.job.wheel_radius_mm - cfg_.wear_mm});
  cut_since_capture_ = true, fresh_ = false;
}

void GrindStation::SetMachineError(const Vec2& error_mm) {
  if (error_mm.allFinite()) cfg_.machine_error_mm = error_mm;
}

StationMeasurement GrindStation::Measure(const StrokeTop& top, const Vec2& c) const {
  StationMeasurement m;
  m.top = top, m.c_mm = c;
  const GrindJob& job = cfg_.job;
  m.mi_mm = nominal_.Closest(c).point;
  if (std::abs((m.mi_mm - c).norm() - job.wheel_radius_mm) > 0.01 * job.wheel_radius_mm) {
    m.refused = true, m.why = "C is not a wheel's radius off the nominal";
    return m;
  }
  const int w = job.camera.width_px, h = job.camera.height_px;
  try {
    m.point = MeasurePoint({{before_.data(), w, h}, {last_frame_.data(), w, h}, c, m.mi_mm},
                           nominal_, job.camera, job.wheel_radius_mm, job.limit_mm, job.bevel);
  } catch (const GrindError& e) {
    m.refused = true, m.why = e.what();
    return m;
  }
  if (!m.point.compensation_withheld.empty())
    m.why = "compensation withheld: " + m.point.compensation_withheld;
  if (m.point.compensation_mm.norm() > cfg_.max_compensation_mm) {
    m.refused = true;
    m.why = "the compensation's " + std::to_string(m.point.compensation_mm.norm() * 1e3) +
            " um is over the limit of " + std::to_string(cfg_.max_compensation_mm * 1e3) + " um";
  }
  return m;
}

std::optional<StationMeasurement> GrindStation::Step(double time_s,
                                                     const Vec2& slide_mm,
                                                     double height_mm,
                                                     const Vec2& nc_c_mm) {
  if (!slide_mm.allFinite() || !nc_c_mm.allFinite() || !std::isfinite(height_mm))
    return std::nullopt;
  if (height_mm < cfg_.work_top_mm) Cut(slide_mm, nc_c_mm);
  const std::optional<StrokeTop> top = trigger_.Add(time_s, height_mm);
  if (!top || !top->capture) return std::nullopt;
  ++captures_;
  last_frame_ = RenderGrindFrame(nominal_, cfg_.job.stock_mm, strokes_, cfg_.job.camera, seed_++,
                                 cfg_.job.bevel);
  const bool measure = cut_since_capture_ && cut_c_ && (*cut_c_ - nc_c_mm).norm() <= kSamePlaceMm;
  cut_since_capture_ = false;
  if (!measure) return std::nullopt;
  fresh_ = true;
  return Measure(*top, nc_c_mm);
}

}  // namespace mlp::grind
