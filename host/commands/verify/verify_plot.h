#pragma once
// The picture of an `mlp verify` result (its JSON, verify_command.cc): the length errors against
// their MPE envelope and the probing views' form figures against theirs, as an SVG.

#include <string>

#include <nlohmann/json.hpp>

namespace mlp::host {

std::string VerifyPlotSvg(const nlohmann::json& result);

}  // namespace mlp::host
