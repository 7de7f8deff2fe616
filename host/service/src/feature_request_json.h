#pragma once
// A measure request's feature part read from its JSON (internal to mlp_service): the nominal
// (request.feature, request.nominal) and the size decided on, its tolerances and limits, every
// field checked before any capture is loaded. What each feature is and how it is measured:
// mlp::jobs (measure_feature.h).

#include "mlp/jobs/measure_feature.h"

#include <string>

#include "job_common.h"
#include <nlohmann/json.hpp>

namespace mlp::service {

/// request.feature and request.nominal. Throws JobInputError (an unknown feature, listing the
/// known ones; a field missing or wrong). `data_dir` resolves relative nominal files.
jobs::FeatureNominal ParseFeatureNominal(const nlohmann::json& request,
                                         const std::string& data_dir);

/// The nominal, and the size, tolerances and limits a measure request gives it. Throws
/// JobInputError.
jobs::FeatureRequest ParseFeatureRequest(const nlohmann::json& request,
                                         const std::string& data_dir);

}  // namespace mlp::service
