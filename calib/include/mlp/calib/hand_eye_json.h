#pragma once
/// @file The hand-eye and recheck results as JSON: the one writer of each, used by `mlp calibrate
/// hand-eye | recheck --json` and by the service's calibrate and recheck jobs, so that both
/// report the same fields (docs/CALIBRATION.md).

#include "mlp/calib/hand_eye.h"
#include "mlp/calib/recheck.h"

#include <nlohmann/json.hpp>

namespace mlp::calib {

/// M, its standard deviations, the sphere centre, the fit's figures, each capture's, the
/// sensor model when estimated, the leave-one-out validation and the warnings. Lengths in mm,
/// rotations as rotation vectors in rad.
nlohmann::ordered_json HandEyeResultJson(const HandEyeResult& r);

/// A quick recheck: whether a full calibration is required and why, the new M, the change of
/// the mounting and of the sphere, the residuals before and after per capture, the apparent
/// radius change, the depth scale and what the captures could not determine.
nlohmann::ordered_json RecheckResultJson(const RecheckResult& r);

}  // namespace mlp::calib
