#pragma once
/// @file The alignment job (docs/HOSTD.md `{"op": "align"}`, seed 004), typed: a part's datum
/// frame from its features -> the work offset (origin, rotation about Z) the controller is to
/// get, with the readings of every feature and the plausibility gate's refusal. Plane A is the
/// primary datum; the secondary and tertiary are two bores' axes on it (plane-circle-circle) or
/// a line and a point (plane-line-point, 3-2-1; plane-plane-plane is the same with faces).

#include "mlp/features/decision.h"
#include "mlp/features/feature.h"
#include "mlp/geometry/datum.h"
#include "mlp/jobs/evidence.h"
#include "mlp/jobs/readings.h"
#include "mlp/jobs/request_error.h"
#include "mlp/nc/nc_output.h"

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

namespace mlp::jobs {

/// A face: its nominal and the captures' points.
struct FaceInput {
  features::PlaneNominal nominal;
  Evidence evidence;
};
/// A hole measured as a bore: its fitted axis where it meets plane A.
struct HoleInput {
  features::BoreNominal nominal;
  Evidence evidence;
};
/// A part edge on plane A from the LED frames of edge captures (every capture holds an edge).
struct EdgeInput {
  Evidence evidence;
};
/// A part edge as two touch points in machine coordinates (p -> q is X), at least
/// kMinTouchSpanMm apart.
struct TouchPoints {
  geometry::Vec3 p = geometry::Vec3::Zero(), q = geometry::Vec3::Zero();
};
/// A point given in machine coordinates.
struct GivenPoint {
  geometry::Vec3 point_mcs = geometry::Vec3::Zero();
};

/// Two touch points closer than this make X from their scatter, not from the edge.
inline constexpr double kMinTouchSpanMm = 5.0;

struct AlignInputs {
  std::string method;  ///< "plane-circle-circle", "plane-line-point", "plane-plane-plane"
  int work_offset = 0;
  std::optional<geometry::Vec3> expected_origin_mm;  ///< the gate's work-shift check
  FaceInput plane_a;
  /// plane-circle-circle: the origin at B's axis on A, X towards C's.
  std::optional<HoleInput> circle_b, circle_c;
  /// plane-line-point: the secondary line, face B's trace on A ("plane_b") or a part edge
  /// ("line_b": touch points or edge captures; X runs with the part on +Y) ...
  std::variant<std::monostate, FaceInput, TouchPoints, EdgeInput> line_b;
  /// ... and the tertiary point: face C where the line meets it ("plane_c"), a hole's axis on
  /// A ("hole_c"), a corner where an edge meets the line ("edge_c"), a given point ("point_c").
  std::variant<std::monostate, FaceInput, HoleInput, EdgeInput, GivenPoint> point_c;
};

struct AlignOutcome {
  geometry::Pose3 mcs_from_work = geometry::Pose3::Identity();
  geometry::WorkOffsetReading work;  ///< the frame read as a work offset
  /// Each feature's numbers under its request name ("plane_a", "circle_b", "line_b", ...).
  Readings readings;
  features::FitEvidence fe;
  /// The plausibility gate's problems: any one means nothing is written.
  std::vector<std::string> refusal;
};

/// The datum frame and the gate. Throws features::FeatureError (a feature not measurable from
/// its points) and RequestError (a geometry that fixes no frame: plane C along the line, an
/// edge within 10 deg of it, touch points too close).
AlignOutcome AssessAlign(const AlignInputs& inputs,
                         const CalibrationFacts& calibration,
                         const features::PlausibilityLimits& limits);

/// The work offset (origin and rotation about Z, absolute) and, with `named_parameters`
/// (LinuxCNC), #<_mlp_status> and #<_mlp_rotation>.
nc::NcResult AlignChanges(const AlignOutcome& outcome,
                          const AlignInputs& inputs,
                          std::int64_t job,
                          bool named_parameters);

}  // namespace mlp::jobs
