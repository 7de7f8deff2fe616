#pragma once
/// @file The virtual probe's world: a workpiece as constructive solid geometry (CSG) of
/// half-spaces, boxes, spheres, cylinders and cones, each with a Lambertian reflectance; where
/// the probe is mounted on the flange; and the flange pose of each capture. File format:
/// docs/SCENE.md. Ray casting follows Roth, "Ray casting for modeling solids" (CGIP 18, 1982):
/// every solid returns the intervals of a ray inside it, and CSG combines interval lists.

#include "mlp/base/input_error.h"
#include "mlp/geometry/types.h"

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <boost/container/small_vector.hpp>

namespace mlp::sim {

using geometry::Pose3;
using geometry::Vec3;

struct Ray {
  Vec3 origin;
  Vec3 direction;  ///< unit
};

/// The glossy part of a surface's reflectance (brdf.h): a microfacet lobe of Fresnel reflectance
/// `specular_f0` at normal incidence and GGX roughness alpha. The default is none: a matt face.
struct Gloss {
  double specular_f0 = 0.0;  ///< 0..1 (iron ~0.55, aluminium ~0.9 in blue light)
  double roughness = 1.0;    ///< GGX alpha, 0.005..1 (small: mirror-like; a polished mirror ~0.005)
};

/// Where a ray crosses the boundary of a solid: ray parameter [mm], outward unit normal of the
/// solid there, diffuse (Lambertian) reflectance of that surface (0..1) and its gloss.
struct SurfaceHit {
  double t = 0.0;
  Vec3 normal = Vec3::Zero();
  double reflectance = 0.0;
  Gloss gloss;
};

/// One interval of the ray inside a solid (t may be +-infinity for unbounded solids).
struct Span {
  SurfaceHit in, out;
};

/// A ray's spans in a solid. A ray crosses a part's solid a few times, so the list is kept on
/// the stack: a heap list per ray and per CSG node was most of a frame's time under
/// AddressSanitizer, whose allocator records a stack trace per allocation.
using SpanList = boost::container::small_vector<Span, 8>;

class Solid {
 public:
  virtual ~Solid() = default;
  /// Appends the sorted, disjoint spans of `ray` inside the solid.
  virtual void Spans(const Ray& ray, SpanList* out) const = 0;
  /// Whether any face has a specular lobe (then light reflects onto other faces).
  virtual bool Glossy() const { return false; }
};

using SolidPtr = std::shared_ptr<const Solid>;

/// Solid side n.(x - point) <= 0 of a plane (its face looks along `normal`).
SolidPtr MakeHalfspace(const Vec3& point, const Vec3& normal, double reflectance);
/// Axis-aligned box.
SolidPtr MakeBox(const Vec3& min_corner, const Vec3& max_corner, double reflectance);
SolidPtr MakeSphere(const Vec3& center, double radius, double reflectance);
/// Capped cylinder (radius_top == radius_base) or cone frustum from `base` along `axis`.
SolidPtr MakeRevolution(const Vec3& base,
                        const Vec3& axis,
                        double length,
                        double radius_base,
                        double radius_top,
                        double reflectance);
/// A planar calibration target: a plate 5 mm thick whose face is the board's z = 0 plane,
/// facing +z, with a chessboard of (inner_cols + 1) x (inner_rows + 1) squares of `square_mm`
/// starting at the board origin (inner corners at (i, j) * square_mm, i = 1..inner_cols,
/// j = 1..inner_rows) and a white margin of one square around it.
SolidPtr MakeChessboard(const Pose3& mcs_from_board,
                        int inner_cols,
                        int inner_rows,
                        double square_mm,
                        double light_reflectance,
                        double dark_reflectance);
/// The same solid with every face given `gloss` and, when `diffuse` is >= 0, that diffuse
/// reflectance (a finish: ground, milled, cast, coated).
SolidPtr MakeFinish(SolidPtr solid, const Gloss& gloss, double diffuse = -1.0);
/// The same solid in a named finish of machined parts (`matt_coated`, `ground_steel`,
/// `milled_aluminium`, `cast_iron`: docs/PROBE.md, "Materials"); throws SceneError naming the
/// known ones for any other name.
SolidPtr MakeNamedFinish(SolidPtr solid, const std::string& name);
SolidPtr MakeUnion(std::vector<SolidPtr> parts);
SolidPtr MakeIntersection(std::vector<SolidPtr> parts);
/// `a` minus every solid of `b`.
SolidPtr MakeDifference(SolidPtr a, std::vector<SolidPtr> b);

struct Capture {
  std::string id;
  Pose3 mcs_from_flange = Pose3::Identity();  ///< H, as the NC reports it
};

struct Scene {
  SolidPtr workpiece;
  Pose3 flange_from_probe = Pose3::Identity();  ///< the true mounting M (calibration's target)
  std::vector<Capture> captures;

  /// First surface the ray meets beyond t_min.
  std::optional<SurfaceHit> FirstHit(const Ray& ray_in_mcs, double t_min = 1e-6) const;
  /// True when the segment from `from` to `to` (MCS) passes through the workpiece, ignoring the
  /// first and last `margin_mm` (the surfaces the segment starts or ends on).
  bool Blocked(const Vec3& from, const Vec3& to, double margin_mm = 1e-4) const;
};

class SceneError : public base::InputError {
 public:
  using base::InputError::InputError;
};

Scene ParseScene(const std::string& json_text);
Scene LoadScene(const std::string& path);

}  // namespace mlp::sim
