#include "mlp/jobs/recheck.h"

#include "mlp/base/check.h"

namespace mlp::jobs {
namespace {

// The part's reference surface: its feature measured from the reference captures; the
// readings for the reply.
calib::PartSurface ReferenceSurface(const PartArtefact& part, Readings* readings) {
  calib::PartSurface s;
  if (part.bore) {
    const features::BoreMeasurement b =
        features::MeasureBore(part.reference.points_mcs, *part.bore);
    s.kind = calib::PartSurface::Kind::kCylinder;
    s.point_mcs = b.top_centre_mcs, s.direction_mcs = b.axis_mcs, s.radius_mm = b.diameter_mm / 2;
    *readings = {{"feature", "bore"},
                 {"centre_mm", b.top_centre_mcs},
                 {"axis", b.axis_mcs},
                 {"diameter_mm", b.diameter_mm},
                 {"points", b.points}};
    return s;
  }
  MLP_CHECK(part.face.has_value());
  const features::PlaneMeasurement f =
      features::MeasurePlane(part.reference.points_mcs, *part.face);
  s.kind = calib::PartSurface::Kind::kPlane;
  s.point_mcs = f.plane.point, s.direction_mcs = f.plane.normal;
  *readings = {{"feature", "face"},
               {"point_mm", f.plane.point},
               {"normal", f.plane.normal},
               {"points", f.points}};
  return s;
}

}  // namespace

RecheckOutcome AssessRecheck(const RecheckInputs& in, const calib::CalibrationRecord& original) {
  RecheckOutcome o;
  calib::RecheckOptions options;
  options.original_flange_from_probe = original.flange_from_probe;
  if (in.part) {
    const calib::PartSurface surface = ReferenceSurface(*in.part, &o.reference);
    o.artefact = "part";
    options.original_centre_mcs = original.sphere_centre_mcs;  // kept: the sphere was not measured
    o.result = calib::RecheckOnPart(in.captures, surface, options);
    return o;
  }
  options.sphere_radius_mm = in.sphere_radius_mm;
  options.sphere_moved = in.sphere_moved;
  options.original_centre_mcs = in.sphere_centre_mcs.value_or(original.sphere_centre_mcs);
  o.artefact = "sphere";
  o.sphere_centre_from =
      in.sphere_centre_mcs ? "the request (another probe)" : "the full calibration";
  o.result = calib::Recheck(in.captures, options);
  return o;
}

}  // namespace mlp::jobs
