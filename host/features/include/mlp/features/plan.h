#pragma once
/// @file Capture plans from a feature's nominal: which views (flange poses H), and in each the
/// region of interest the probe triangulates (the sensor window, AOI, and the projector columns
/// that light it). The firmware then reads and sends only that region (DESIGN.md: the probe
/// triangulates only the ROI), so a capture costs what the feature needs, not a full frame.
///
/// A view looks at a patch of the nominal surface from the probe's working distance: faces
/// square on, walls of bores, bosses, slots, webs and pockets from above, the view tilted
/// `wall_tilt_deg` from the wall's axis towards the wall (seen straight down a wall is
/// edge-on; square on from its side the probe would be inside the part). The pose is the probe's
/// camera frame P there, so the flange pose is H = P M^-1 with the hand-eye M. Reaching a tilted H
/// needs a machine that tilts the spindle or a probe mounted at an angle; on a 3-axis machine only
/// the spindle orientation (a turn about Z) is free, and the plan says so (CheckReachable).

#include "mlp/features/composite.h"
#include "mlp/features/edge.h"
#include "mlp/features/surface.h"
#include "mlp/geometry/types.h"
#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/probe_model.h"

#include <optional>
#include <string>
#include <vector>

namespace mlp::features {

struct PlanOptions {
  double standoff_mm = 120.0;  ///< camera centre to the aimed point: the probe's working distance
  /// A wall's view: tilted this far from straight down its axis, towards the wall.
  double wall_tilt_deg = 30.0;
  double patch_mm = 8.0;        ///< size of the surface patch each view triangulates
  double aoi_margin_px = 16.0;  ///< around the patch's image
  double column_margin = 3.0;   ///< projector columns beyond the patch's
  double column_step = 2.0;     ///< columns between laser frames
  int views_per_circle = 4;     ///< bores, bosses, holes of a bolt circle, ellipses
  void Check() const;           ///< throws FeatureError naming the option out of range
};

/// What a view must see: its camera frame in the machine (z towards the surface, x across it)
/// and points of the nominal surface its region of interest must hold.
struct ViewTarget {
  std::string id;
  geometry::Pose3 mcs_from_camera = geometry::Pose3::Identity();
  geometry::Points3 patch_mcs;
  /// A view of a straight edge: the point on it whose image is the firmware's hint for the
  /// edge ROI ("edge:x,y", probe_fw/roi_spec.h).
  std::optional<geometry::Vec3> edge_hint_mcs;
};

struct PlannedCapture {
  std::string id;
  geometry::Pose3 mcs_from_flange = geometry::Pose3::Identity();
  probe_fw::Aoi aoi;
  double first_column = 0.0, last_column = 0.0, column_step = 2.0;
  std::string roi = "full";  ///< the firmware's ROI_SPEC
};

/// The views of each feature (one per face, `views_per_circle` per circular wall).
std::vector<ViewTarget> FaceViews(const std::string& id,
                                  const PlaneNominal& n,
                                  const PlanOptions& o);
std::vector<ViewTarget> BoreViews(const std::string& id,
                                  const BoreNominal& n,
                                  const PlanOptions& o);
std::vector<ViewTarget> WidthViews(const WidthNominal& n, const PlanOptions& o);
std::vector<ViewTarget> RectangleViews(const RectangleNominal& n, const PlanOptions& o);
std::vector<ViewTarget> EllipseViews(const EllipseNominal& n, const PlanOptions& o);
std::vector<ViewTarget> SurfaceViews(const SurfaceNominal& n, const PlanOptions& o);
/// `n.views` views square on the face, spread evenly over `n.length_mm` of the edge (one: at its
/// point), each aimed at the edge so that its rays there run along the face's normal; the
/// camera's x along the edge.
std::vector<ViewTarget> EdgeViews(const std::string& id,
                                  const EdgeNominal& n,
                                  const PlanOptions& o);

/// The flange pose, AOI and columns of each view for this probe (its camera and projector model)
/// mounted with `flange_from_probe` (M). Throws FeatureError when a view's patch is not in front
/// of the camera or falls outside the sensor (the nominal or the standoff is wrong).
std::vector<PlannedCapture> PlanCaptures(const std::vector<ViewTarget>& views,
                                         const probe_fw::ProbeModel& probe,
                                         const geometry::Pose3& flange_from_probe,
                                         const PlanOptions& options);

/// Empty when every planned H keeps the spindle untilted (its flange's z down the machine's -Z,
/// H = T Rz Rx(180 deg), within 0.01 deg), otherwise the first view that needs a tilt and how
/// much: a 3-axis machine orients its spindle about Z and nothing else.
std::string CheckReachable(const std::vector<PlannedCapture>& plan);

}  // namespace mlp::features
