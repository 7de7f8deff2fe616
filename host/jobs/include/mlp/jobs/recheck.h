#pragma once
/// @file The recheck job (docs/HOSTD.md `{"op": "recheck"}`, seed 002), typed: a few captures
/// of an artefact after a disturbance (a crash, a probe re-mounted) against the probe's full
/// calibration -> the hand-eye corrected, or a refusal that asks for a full calibration. The
/// artefact is the calibration sphere (where it was, moved, or where another probe found it)
/// or a surface of the part measured with the original calibration before the disturbance.

#include "mlp/calib/recheck.h"
#include "mlp/calib/record.h"
#include "mlp/features/feature.h"
#include "mlp/jobs/evidence.h"
#include "mlp/jobs/readings.h"

#include <optional>
#include <string>
#include <vector>

namespace mlp::jobs {

/// A part's feature as the artefact (seed 002's "other feature"): a bore or a face, with the
/// reference captures taken before the disturbance, mapped with the original calibration.
struct PartArtefact {
  std::optional<features::BoreNominal> bore;
  std::optional<features::PlaneNominal> face;  ///< when not a bore
  Evidence reference;
};

struct RecheckInputs {
  std::optional<PartArtefact> part;  ///< instead of the sphere
  double sphere_radius_mm = 0.0;
  bool sphere_moved = false;
  /// The sphere's centre measured by another probe (a touch probe after re-mounting it): the
  /// reference instead of the full calibration's centre.
  std::optional<geometry::Vec3> sphere_centre_mcs;
  std::vector<calib::RecheckCapture> captures;  ///< after the disturbance
};

struct RecheckOutcome {
  calib::RecheckResult result;
  std::string artefact;            ///< "sphere" or "part"
  std::string sphere_centre_from;  ///< the sphere's: "the full calibration" or "the request ..."
  Readings reference;              ///< the part's reference surface as measured
};

/// The recheck against `original` (a sphere calibration). Throws features::FeatureError (the
/// part's reference not measurable) and calib's errors.
RecheckOutcome AssessRecheck(const RecheckInputs& inputs, const calib::CalibrationRecord& original);

}  // namespace mlp::jobs
