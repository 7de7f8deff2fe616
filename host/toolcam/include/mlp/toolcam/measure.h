#pragma once
/// @file A tool measured from its strobed shadow images (seed 000): the silhouette's sub-pixel
/// outline in each image (geometry/contour.h), angular indexing without an encoder (the
/// outline's extreme +y at a reference height against the images' angular order: its maxima
/// are the flutes, the nearest images their principal images; an EDM electrode's by that
/// function shifted against its model's), then per flute the reference
/// edge model (the tool description's nominal silhouette) shifted in y (radius) and z (length)
/// by least squares, contamination (coolant, chips) removed, and what stays off the model
/// reported as wear (inside) and build-up (outside).

#include "mlp/geometry/types.h"
#include "mlp/toolcam/tool_camera.h"
#include "mlp/toolcam/tool_model.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

namespace mlp::toolcam {

/// A frame's silhouette outline in the tool frame (y across, h up from the nominal tip) [mm]:
/// `side` from the rows (the +y flank), `side_neg` the -y flank where the image shows the
/// spindle axis' other side (a small tool wholly in view, seed 000 example 1), `bottom` from
/// the columns (the end).
struct Outline {
  std::vector<geometry::Vec2> side, side_neg, bottom;
  /// The end under columns light at the top, below a shadow at least 0.12 mm tall: where a
  /// helix turns the flank in above the end (a helical flute's corner, examined in the image
  /// where the end faces the side). Apart: a drop on the flank makes such columns too.
  std::vector<geometry::Vec2> bottom_open;
};

/// Sub-pixel outline of one frame, undistorted and mapped with the camera's calibration.
Outline ExtractOutline(const std::vector<std::uint8_t>& pixels, const ToolCameraModel& camera);
/// Half way between a frame's shadow and back-light grey (its 2nd and 98th percentiles: a real
/// light source ages, so the level comes from the image itself).
double ShadowLevel(const std::vector<std::uint8_t>& pixels);
/// A pixel position in the tool frame (y, h) [mm]: undistorted, then the camera's calibration.
geometry::Vec2 ToolFromImage(const geometry::Vec2& pixel, const ToolCameraModel& camera);

struct MeasureOptions {
  /// The height that indexes the flutes (above the corner); ForTool chooses it for a tool.
  double h_ref_mm = kDefaultReferenceHeightMm;
  static constexpr double kDefaultReferenceHeightMm = 1.5;
  /// Half the band round it: the flank over it is smoothed (a quadratic in h) with what sticks
  /// out by more than `contamination_mm` left out, so a drop or a build-up there does not move
  /// the indexing (seed 000 example 3).
  double band_mm = 0.2;
  /// Outside the model by more than this and shorter than `contamination_length_mm`: coolant,
  /// a chip, oil (removed, the fit repeated).
  double contamination_mm = 0.003;
  double contamination_length_mm = 0.15;
  /// A stretch of the edge off the model by more than this, at least `finding_length_mm` long:
  /// wear (inside) or build-up (outside).
  double finding_mm = 0.004;
  double finding_length_mm = 0.03;
  int rounds = 4;
  /// The tool's turn while a pulse lasts [rad] (pulse width x angular speed, from the strobe
  /// plan): the image is the average over it, and so is the model (5 angles, as the virtual
  /// camera); a long pulse otherwise shrinks every edge by r (1 - cos(blur / 4)).
  double blur_rad = 0.0;
  /// The turn at the series' angular position 0 [deg], when the chuck defines it (an EDM's C
  /// axis, a spindle's oriented stop); else unset. An electrode's section looks the same after
  /// half a turn, so its corners are named by this (the shadow function's overlap is taken
  /// within a quarter turn of it), by a stored reference's wear, or not at all
  /// (ToolMeasurement::half_turn_ambiguous).
  std::optional<double> start_turn_deg;
};

/// The options for a tool: the defaults with its file's reference height, or one chosen for
/// its shape: 1.5 mm, lowered to an eighth of the helix' lead above the end's shape (a small
/// helical tool's edges turn face-on within a few mm), at least 0.4 mm above it.
MeasureOptions ForTool(const ToolDescription& tool);

/// A stretch of an edge off its model.
struct Finding {
  bool buildup = false;  ///< outside the model; else wear (inside)
  /// On the end (the underside's outline: the end face and the corner, found along y), else
  /// on the flank (along h).
  bool on_end = false;
  /// A worn corner: the flank's lowest stretch and the end's outermost one, each too short
  /// alone, together (on_end too; h the flank's lowest point, y the end's outermost).
  bool corner = false;
  double h_mm = 0.0;  ///< its middle's height above the nominal tip
  double y_mm = 0.0;  ///< an end finding's middle across the axis (tool frame), else 0
  double length_mm = 0.0, max_mm = 0.0, area_mm2 = 0.0;
};

/// One edge seen in one image: its principal image on the +y flank (`side` +1) or, with the
/// spindle axis in view, on the -y flank (-1; measured mirrored, figures as the edge's own).
struct FluteView {
  int side = 1;
  int frame = 0;  ///< the image (index into the frames given)
  /// Measured in the image nearest the edge's peak; false: in a neighbour, the nearest refused
  /// (a drop or chip on the edge there).
  bool principal = true;
  /// A helical flute's end examined for corner wear in this image (where the end faces the
  /// side); -1: that image refused (the corner not examined); -2: its own image.
  int end_frame = -2;
  double angle_deg = 0.0;  ///< where its extreme lies in the images' angular order
  double radius_mm = 0.0;  ///< the edge's distance from the calibrated axis
  double tip_h_mm = 0.0;   ///< its tip above the nominal tip (negative: longer)
  double rms_mm = 0.0;     ///< of the outline about the shifted model
  /// Standard uncertainties (k = 1) of radius and tip from the fit's covariance: what the
  /// outline's noise leaves open (not the calibration's share).
  double radius_u_mm = 0.0, tip_u_mm = 0.0;
  int points = 0, removed = 0;  ///< used; left out as contamination or findings
  std::vector<Finding> findings;
  /// For the overlay, in the tool frame [mm]: the fitted model's outline (flank from the top
  /// down, then the underside), and each outline point with what it was taken for.
  std::vector<geometry::Vec2> model_yh;
  enum PointKind { kUsed, kContamination, kWear, kBuildup };
  std::vector<geometry::Vec2> points_yh;
  std::vector<PointKind> point_kind;
  /// The edge's shape off its ground edge along h, every 0.01 mm (h, dr) [mm]: the reference's
  /// own shape plus what this view found (a stored reference keeps it).
  std::vector<std::pair<double, double>> profile;
};

struct FluteMeasurement {
  /// The reference's edge it was measured against: the nominal's (unequal pitch: the one the
  /// pitches say) or a stored reference's (matched by radii and tips).
  int edge = 0;
  FluteView plus;                  ///< its +y principal image
  std::optional<FluteView> minus;  ///< its -y principal image, with the axis in view
  /// The edge's radius about the spindle axis: with both flanks the views' mean, where the
  /// axis' error in the camera's calibration cancels (+ on one side, - on the other).
  double radius_mm = 0.0;
  double tip_h_mm = 0.0;  ///< the views' mean
  /// Their standard uncertainties (k = 1) from the views' fits (the mean's, with both).
  double radius_u_mm = 0.0, tip_u_mm = 0.0;
  double angle_deg = 0.0;  ///< the +y view's
  /// An electrode's corner: how far it moved in since the nominal (or the stored reference),
  /// across the axis and up from the end [mm] (negative: it grew).
  double radial_wear_mm = 0.0, axial_wear_mm = 0.0;
  /// Both views' findings.
  std::vector<const Finding*> Findings() const;
};

struct ToolMeasurement {
  std::vector<FluteMeasurement> flutes;  ///< in order round the tool from the highest peak
  double radius_mm = 0.0;                ///< the largest edge's: what cuts the wall
  double tip_h_mm = 0.0;                 ///< the longest edge's: what cuts the floor
  double runout_mm = 0.0;                ///< largest minus smallest edge radius
  /// The edges' radii as a centre off the spindle axis: r_k = r0 + e cos(angle_k - phase).
  double eccentricity_mm = 0.0, eccentricity_deg = 0.0;
  /// Both flanks seen (the axis in view): the spindle axis' offset across the image from where
  /// the camera's calibration puts it [mm] (half the +y and -y radii's mean difference).
  bool both_flanks = false;
  double axis_offset_mm = 0.0;
  /// The worst finding's distance from the model [mm] (0: none) and whether it exceeds the
  /// tool's wear limit (the tool table is then not written).
  double worst_finding_mm = 0.0;
  /// An electrode: its most worn corner's wear, radial or axial [mm] (seed 000 example 5: the
  /// controller decides from it whether the electrode may go on); 0 for a cutter, whose size
  /// goes to the tool table.
  double worst_wear_mm = 0.0;
  /// An electrode whose corners are named only up to a half turn: no chuck angle
  /// (MeasureOptions::start_turn_deg) and no stored reference; corner k may be corner k + 2.
  bool half_turn_ambiguous = false;
  bool OverWearLimit(const ToolDescription& tool) const {
    return std::max(worst_finding_mm, worst_wear_mm) > tool.wear_limit_mm;
  }
};

/// `frames[i]` was taken at angular position `positions[i]` of `position_count` (the strobe
/// plan's order; the absolute angle is unknown). `nominal` is the tool's description; when its
/// edges carry measured data (a stored reference), each flute is matched to its edge (the
/// turn of the edges' order that fits the radii and tips best) and measured against that
/// edge's stored shape, so findings are what changed since. Throws ToolError when the frames
/// do not show the flutes (too few frames, no outline at the reference height).
ToolMeasurement MeasureTool(const std::vector<std::vector<std::uint8_t>>& frames,
                            const std::vector<int>& positions,
                            int position_count,
                            const ToolDescription& nominal,
                            const ToolCameraModel& camera,
                            const MeasureOptions& options = {});

/// One series of a tool's images: each frame with its angular position of `position_count`,
/// and the camera as it stood for them (its calibration with the spindle's shift).
struct ToolSeries {
  const std::vector<std::vector<std::uint8_t>>& frames;
  const std::vector<int>& positions;
  int position_count = 0;
  const ToolCameraModel& camera;
  /// Each frame's angle as measured (an encoder, the strobe's timestamp) [deg], counted as the
  /// positions are: used in their place (ToolImages::angle_deg). Null or empty: the positions.
  const std::vector<double>* angle_deg = nullptr;
  /// Each frame's pulse as the tool's turn during it [rad] (ToolImages::image_blur_rad). Null or
  /// empty: MeasureOptions::blur_rad for all.
  const std::vector<double>* blur_rad = nullptr;
};

/// MeasureTool on one series whose frames may carry measured angles and their own pulses.
ToolMeasurement MeasureTool(const ToolSeries& series,
                            const ToolDescription& nominal,
                            const MeasureOptions& options = {});

/// A tool wider than the field on both its sides (seed 000 examples 2 and 3): `plus` shows its
/// +y flank; then the NC moved the spindle across by about its diameter and `minus` shows its
/// -y flank, each series starting at an unknown angle. Each edge is named on both sides (by
/// the pitches; equal pitch: by the turn of the order that fits the edges' tips and radii'
/// pattern best, all alike when the tool runs true) and its radius is the two sides' mean:
/// the axis' error (the camera's calibration and the move across) cancels and is
/// `axis_offset_mm`. Throws as MeasureTool, and ToolInputError when a series shows the wrong
/// side.
ToolMeasurement MeasureToolBothSides(const ToolSeries& plus,
                                     const ToolSeries& minus,
                                     const ToolDescription& nominal,
                                     const MeasureOptions& options = {});

/// The measured tool as its new reference: the nominal's description with each edge's measured
/// runout, length and shape (profile), edge 0 the flute of the highest peak (or the edges
/// matched against a reference, kept).
ToolDescription ReferenceFrom(const ToolDescription& nominal, const ToolMeasurement& measured);

}  // namespace mlp::toolcam
