#include "mlp/probe_fw/triangulate.h"

#include "mlp/probe_fw/epipolar.h"
#include "mlp/probe_fw/ghost.h"
#include "mlp/probe_fw/reflectance.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace mlp::probe_fw {

namespace {

// Fixed-point steps on a curved sheet: the smile moves the plane by a fraction of a column, so
// each step shrinks the error by that column's share of the point's along-line change (~1e-4).
constexpr int kSheetSteps = 8;
constexpr double kSheetTolMm = 1e-10;

std::optional<Vec3> OnPlane(const ProjectorModel& projector,
                            const Vec3& ray,
                            double planar_column) {
  Vec3 normal;
  double offset = 0.0;
  projector.PlaneOf(planar_column, &normal, &offset);
  const double denom = normal.dot(ray);
  // Below 1e-3 the ray grazes the plane (triangulation angle < 0.06 deg): no depth resolution.
  if (!(std::abs(denom) > 1e-3 * ray.norm())) return std::nullopt;
  return (offset / denom) * ray;
}

// The options with smoothing along the stripe as the sweep's middle laser frame calls for
// (EstimateSpeckle): one frame's thousand-odd centres measure the grain; the whole sweep is then
// read alike. Under measured speckle the profile's own grains make humps inside the centroid
// window, so only a peak beyond the window is a second stripe.
StripeOptions WithSpeckleSmoothing(const std::vector<Frame>& frames,
                                   const RowMask& mask,
                                   StripeOptions options,
                                   EpipolarOptions* epipolar) {
  if (options.along_stripe_sigma_px > 0.0) return options;
  std::vector<const Frame*> laser;
  for (const Frame& f : frames) {
    if (f.IsLaser()) laser.push_back(&f);
  }
  if (laser.empty()) return options;
  std::vector<StripePoint> stripe;
  StripeCounts ignored;
  StripeExtractor(mask, options).Extract(*laser[laser.size() / 2], &stripe, &ignored);
  const SpeckleEstimate speckle = EstimateSpeckle(stripe, *epipolar);
  options.along_stripe_sigma_px = AlongStripeSigmaPx(speckle);
  epipolar->smooth_half_lines = SmoothHalfLines(speckle, epipolar->smooth_half_lines);
  if (options.along_stripe_sigma_px > 0.0) options.double_peak_min_px = options.window_half_px + 1;
  return options;
}

// The scans as the probe's epipolar geometry wants them: the scan along the epipolar lines (the
// axis along which direct light moves) owns a crossing unless the other crosses the stripe
// kCrossScanDominance times more squarely: an angle of about 72 deg to the epipolar scan's
// normal, where that scan's profile is three times its width and the stripe runs nearly along
// the epipolar lines (the faces the light grazes, which only the other scan can measure).
constexpr double kCrossScanDominance = 3.0;
StripeOptions OnEpipolarLines(const GhostOptions& motion, StripeOptions options) {
  if ((motion.row_motion_sign != 0.0) == (motion.column_motion_sign != 0.0)) return options;
  options.epipolar_axis = motion.row_motion_sign != 0.0 ? ScanAxis::kRow : ScanAxis::kColumn;
  options.cross_scan_dominance = kCrossScanDominance;
  return options;
}

}  // namespace

std::optional<Vec3> Triangulate(const ProbeModel& model, double x_px, double y_px, double column) {
  const Vec2 xy = model.camera.Undistort(Vec2(x_px, y_px));
  const Vec3 ray(xy.x(), xy.y(), 1.0);
  const ProjectorModel& projector = model.projector;
  const double actual = projector.ActualColumn(column);
  std::optional<Vec3> point = OnPlane(projector, ray, actual);
  if (!point || projector.sheet_smile_cols == 0.0) return point;
  // The curved sheet of `actual` meets the ray where the point's planar column is actual plus
  // the smile at the point's own position along the line.
  const Pose3 projector_from_probe = projector.camera_from_projector.inverse();
  for (int step = 0; step < kSheetSteps; ++step) {
    const Vec3 q = projector_from_probe * *point;
    const std::optional<Vec3> next =
        OnPlane(projector, ray, actual + projector.SmileAt(q.y() / q.z()));
    if (!next) return std::nullopt;
    const double moved = (*next - *point).norm();
    point = next;
    if (moved < kSheetTolMm) break;
  }
  return point;
}

// Back-steps along a line that the ordering test lets pass [px]: a fine sweep's neighbouring
// frames light one pixel, and their centres scatter by a tenth of a pixel (more under speckle).
constexpr double kOrderTolerancePx = 1.0;
// A back-step a reflection's run makes between frames [px]: several times the centres' scatter
// under speckle (0.1-0.5 px), so a fine sweep's noise never strings two together.
constexpr double kBackStepPx = 2.0;

namespace {

// The sweep's tests for light from elsewhere, in this order, one statement each (each test reads
// what the one before marked). Returns the centres they took out of the cloud, counted once each:
// one the order doubted (still a reference) may later be found indirect too.
std::uint64_t MarkIndirectLight(const ProbeModel& model,
                                const GhostOptions& ghost,
                                const std::vector<SweepObservation>& evidence,
                                std::vector<SweepObservation>* seen) {
  const double rows = ghost.row_motion_sign, columns = ghost.column_motion_sign;
  RejectIndirectLight(seen, ghost);
  RejectRayConflicts(model, RayOptions{}, seen);
  RejectBackwardRuns(rows, columns, kBackStepPx, 2, 2, seen);
  RejectOutOfOrder(rows, columns, kOrderTolerancePx, seen);
  RejectSweptTwice(rows, columns, evidence, SweptOptions{}, seen);
  RejectBehindClippedLight(rows, columns, evidence, kOrderTolerancePx, seen);
  RejectAcrossOrder(rows, columns, kOrderTolerancePx, seen);
  RejectOffRate(rows, columns, RateOptions{}, seen);
  SpreadAlongStripes(EpipolarOptions{}.link_gate_px, EpipolarOptions{}.max_line_gap, 0.5, seen);
  return static_cast<std::uint64_t>(
      std::count_if(seen->begin(), seen->end(),
                    [](const SweepObservation& o) { return o.indirect || o.doubted; }));
}

}  // namespace

std::vector<CloudPoint> ReconstructSweep(const ProbeModel& model,
                                         const std::vector<Frame>& laser_frames,
                                         const RowMask& mask,
                                         const StripeOptions& options,
                                         StripeCounts* counts) {
  // The whole sweep's stripe centres first: indirect light is told by the sweep, not a frame.
  std::vector<SweepObservation> seen, evidence;
  std::vector<StripePoint> stripe, rejected;
  EpipolarOptions epipolar;
  GhostOptions ghost;
  DirectMotion(model, &ghost.row_motion_sign, &ghost.column_motion_sign);
  StripeExtractor extractor(
      mask, WithSpeckleSmoothing(laser_frames, mask, OnEpipolarLines(ghost, options), &epipolar));
  int index = 0;
  for (const Frame& frame : laser_frames) {
    if (!frame.IsLaser()) continue;
    stripe.clear(), rejected.clear();
    extractor.Extract(frame, &stripe, counts, &rejected);
    EpipolarCounts held;
    KeepOneDirectPerEpipolarLine(model, rejected, epipolar, &stripe, &held);
    counts->second_on_line += held.second_on_line;
    counts->undecided_on_line += held.undecided;
    counts->beside_rejected += held.beside_rejected;
    counts->isolated += held.isolated;
    counts->points -= held.second_on_line + held.undecided + held.beside_rejected + held.isolated;
    for (const StripePoint& s : stripe) seen.push_back({s, frame.laser_column, index, false});
    for (const StripePoint& s : rejected) {
      if (!s.cut) evidence.push_back({s, frame.laser_column, index, true});
    }
    ++index;
  }
  const std::uint64_t indirect = MarkIndirectLight(model, ghost, evidence, &seen);
  counts->indirect += indirect;
  counts->points -= indirect;
  const ReflectanceCounts slope = CorrectReflectanceSlope(&seen, ReflectanceOptions{});
  counts->reflectance_dropped += slope.dropped;
  counts->points -= slope.dropped;
  std::vector<CloudPoint> cloud;
  for (const SweepObservation& o : seen) {
    if (o.indirect || o.doubted) continue;  // from elsewhere, too uneven, or its order unsure
    CloudPoint p;
    const std::optional<Vec3> point = Triangulate(model, o.stripe.x_px, o.stripe.y_px, o.column);
    // A grazing ray has no depth; behind the camera is no real surface.
    if (!point || !(point->z() > 0.0)) continue;
    p.point_in_probe = *point;
    p.quality = o.stripe.quality;
    p.x_px = o.stripe.x_px;
    p.y_px = o.stripe.y_px;
    p.axis = o.stripe.axis;
    p.column = o.column;
    cloud.push_back(p);
  }
  return cloud;
}

}  // namespace mlp::probe_fw
