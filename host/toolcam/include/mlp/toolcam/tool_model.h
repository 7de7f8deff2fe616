#pragma once
/// @file A cutting tool as the tool camera sees it (format `mlprobe-tool/1`, samples/tools/,
/// docs/TOOLCAM.md): flutes with their cutting edges, each with its own runout (radial offset),
/// length (axial offset), and defects along it (chipped or worn places inside the nominal
/// edge, built-up edge outside). The geometry is what a silhouette shows: each edge's outer
/// radius along the tool and its angle about the axis.
///
/// Tool frame: z along the spindle axis, up into the spindle, 0 at the nominal tip; the tool
/// turns about z. Heights h are mm above the nominal tip.

#include "mlp/base/input_error.h"

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace mlp::toolcam {

/// A measurement or calibration without result: an outline too short, a flute not found.
/// Bad input (a tool, images, camera or calibration file, a camera model or images that do not
/// fit it) is a ToolInputError.
class ToolError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ToolInputError : public base::InputError {
 public:
  using base::InputError::InputError;
};

/// A place along an edge where its radius differs from the ground edge's: smooth (a cosine
/// bell over its length), `depth_mm` > 0 inside (chipped, worn), < 0 outside (built-up edge).
struct EdgeDefect {
  double h_mm = 0.0;       ///< where it starts, above the nominal tip
  double length_mm = 0.0;  ///< along the tool
  double depth_mm = 0.0;
};

struct CuttingEdge {
  double radial_offset_mm = 0.0;  ///< runout: this edge's radius minus the nominal
  double axial_offset_mm = 0.0;   ///< > 0: this edge reaches lower (the tool is longer there)
  std::vector<EdgeDefect> defects;
  /// A measured edge's shape: its radius off the ground edge at heights h [mm], (h, dr) pairs
  /// rising in h, linear between them and 0 outside (what a stored reference keeps).
  std::vector<std::pair<double, double>> profile;
  bool Measured() const {
    return radial_offset_mm != 0 || axial_offset_mm != 0 || !defects.empty() || !profile.empty();
  }
};

/// A calibration pin's blade (seed 000 example 4): a ground rod parallel to the axis below the
/// pin's end, `offset_mm` from the axis along the pin's x (at turn 0), `extends_mm` long (its
/// flat end that far below the pin's end: a pre-calibrated length). Two blades far apart in
/// depth show the view's pitch (their ends' heights differ by their depths times its tangent);
/// ground round, so each looks `width_mm` wide from every side.
struct PinBlade {
  double offset_mm = 0.0, width_mm = 0.0, extends_mm = 0.0;
};

/// What shades one height of the image: up to three disjoint spans across y [mm], rising.
struct ShadowSpans {
  int count = 0;
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
};

struct ToolDescription {
  std::string id;
  double diameter_mm = 0.0;
  double length_mm = 0.0;  ///< gauge point to the nominal tip (the tool table's length)
  int flutes = 0;
  double corner_radius_mm = 0.0;  ///< 0 sharp corner; diameter / 2 a ball nose
  /// A drill's point (or a tap's chamfer): the end a cone of this included angle [deg], its apex
  /// the tip; 0 a flat end (with the corner radius).
  double point_angle_deg = 0.0;
  /// The flat a point is cut off at (a tap's chamfer starts near its minor diameter) [mm]; 0:
  /// a sharp point.
  double tip_diameter_mm = 0.0;
  /// A tap: a 60-degree thread of this pitch [mm] (ISO 68-1's basic profile, depth 5H/8 =
  /// 0.5413 P below the crest, crest flat P/8, root flat P/4), right-hand: edge k's thread is
  /// its flute angle / 360 of a pitch higher than edge 0's. 0: no thread.
  double thread_pitch_mm = 0.0;
  double helix_deg = 0.0;
  /// The helix' hand (`helix_hand`): right, the usual (an edge winds counterclockwise seen
  /// from the spindle as it rises, as a right-hand thread), or left.
  bool left_hand_helix = false;
  /// The cutting hand (`cut`): right, the usual (cuts turning M3, clockwise seen from the
  /// spindle: each tooth's back trails its edge counterclockwise), or left.
  bool left_hand_cut = false;
  /// Each tooth's back, trailing its cutting edge (issue 51; what a silhouette shows beside the
  /// edge as the tool turns): a land of this width along the circle at its relief angle below
  /// the edge's circle, then a body clearance (a drill's body behind its margin, this far
  /// under the radius, flat) or a clearance relief at its angle, to the heel this far round
  /// from the edge; then the flute to the web. land_width_mm 0: a blade (no back drawn).
  double land_width_mm = 0.0;
  double land_relief_deg = 0.0;
  double clearance_relief_deg = 20.0;
  double body_clearance_mm = 0.0;
  double heel_deg = 0.0;  ///< 0: half the smallest pitch
  double flute_length_mm = 0.0;
  /// The web between the flutes: a cylinder of this share of the radius.
  double core_ratio = 0.55;
  /// A calibration pin (`"kind": "pin"`): a plain cylinder of the diameter, its flat end the tip
  /// (h = 0), and either no blades or two below it.
  bool pin = false;
  std::vector<PinBlade> blades;
  /// A touch probe's stylus (`"kind": "stylus"`, seed 000 Fig. 6/7): a ball of the diameter, its
  /// bottom the tip (h = 0), on a stem of `stem_diameter_mm`; one "flute" (edges[0]: its
  /// axial offset moves the ball, as a trigger's deflection does).
  bool stylus = false;
  double stem_diameter_mm = 0.0;
  /// A sinking EDM electrode (`"kind": "electrode"`, seed 000 example 5): a prism of
  /// rectangular section `section_mm` (its width along x, its thickness along y at turn 0),
  /// flat end, turned slowly in the spindle or the C axis. Its four corners are its "flutes":
  /// each a vertical edge at the section's half-diagonal (the diameter is the diagonal), at
  /// angles 0, 180 - 2a, 180, 360 - 2a from corner 0 (a = atan(thickness / width)); each
  /// corner's radial and axial offsets are its own wear (the seed's "each corner may move
  /// independently"). The end's corner radius rounds each corner's bottom.
  bool electrode = false;
  double section_mm[2] = {0.0, 0.0};
  std::vector<CuttingEdge> edges;  ///< one per flute
  /// Each flute's angle about z from flute 0 [deg], rising in [0, 360) (unequal pitch, seed 000
  /// example 3's seven flutes); empty: equal pitch.
  std::vector<double> flute_angles_deg;
  /// The deepest wear or the highest build-up this tool may carry and still be set [mm]: a
  /// finding within it is reported and the tool table written; beyond it, refused. 0: every
  /// finding refuses.
  double wear_limit_mm = 0.0;
  /// The height above the nominal tip whose flank indexes the flutes and names each one's
  /// principal image [mm]: where every flute stands clear on the silhouette (a small drill's
  /// helix turns its flutes face-on within a few mm). 0: the measurement's default (1.5 mm).
  double reference_height_mm = 0.0;

  double Radius() const { return diameter_mm / 2; }
  bool HasBack() const { return land_width_mm > 0; }
  /// The helix' turn per mm of height in the model's angle (clockwise seen from the spindle:
  /// the way M3 turns the tool) [rad/mm].
  double HelixTurnPerMm() const;
  /// Flute k's angle about z from flute 0 [rad].
  double FluteAngle(int k) const;
  bool EqualPitch() const { return flute_angles_deg.empty(); }
  /// How far above the tip the end's shape reaches the full radius: the corner radius, or the
  /// point's (chamfer's) length.
  double EndHeight() const;
  /// Height of edge k's tip above the nominal tip (negative when the edge is longer).
  double TipH(int k) const;
  /// Edge k's outer radius at height h (<= 0 below its tip): corner radius or point, thread,
  /// runout, defects.
  double EdgeRadius(int k, double h_mm) const;
  /// Edge k's angle about z at height h when the tool has turned `turn_rad` (the helix winds
  /// the edge round as it rises).
  double EdgeAngle(int k, double h_mm, double turn_rad) const;
  /// The shadow's extent across height h with the tool turned `turn_rad`, seen along x: each
  /// edge reaching h is a blade from the axis to its radius, plus the web between the flutes.
  /// False where nothing of the tool reaches h.
  bool ShadowSpan(double h_mm, double turn_rad, double* lo_mm, double* hi_mm) const;
  /// The same as disjoint spans (a pin's blades below its end are two), seen with the view's
  /// pitch: a ray at image height h meets depth x at height h + x tan_pitch (tool_camera.h).
  /// A cutter's edge is taken at the depth of its outer point (its silhouette's part).
  ShadowSpans Shadow(double h_mm, double turn_rad, double tan_pitch) const;
  /// Throws ToolInputError naming the first field out of range.
  void Validate() const;

 private:
  double ThreadDepth(double h_mm) const;  ///< below the crest, h from edge 0's crest
  /// Edge k's back at angle `edge_rad` with the edge's radius `r_edge` at this height: widens
  /// [lo, hi] to what the back shades.
  void BackSpan(int k, double edge_rad, double r_edge, double* lo, double* hi) const;
  double PinHalfWidth(double h_mm, double tan_pitch) const;
  double StylusHalfWidth(double h_mm) const;
  ShadowSpans PinShadow(double h_mm, double turn_rad, double tan_pitch) const;
};

/// Parses and validates `mlprobe-tool/1`; throws ToolInputError naming the field.
ToolDescription ParseTool(const std::string& json_text);
ToolDescription LoadTool(const std::string& path);
/// `mlprobe-tool/1` text that ParseTool reads back to the same tool.
std::string ToJson(const ToolDescription& tool);

}  // namespace mlp::toolcam
