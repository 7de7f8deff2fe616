#pragma once
/// @file JSON as text, safely: its own header (nlohmann only) so that the service's request
/// parser, which the fuzz targets compile alone, needs no Eigen.

#include <string>

#include <nlohmann/json.hpp>

namespace mlp::base::json_fields {

/// JSON text for a file, a socket or a broker. Bytes that are not UTF-8 (a peer's serial, a
/// server's error message quoted in a status) become U+FFFD: nlohmann's default dump throws
/// type_error.316 on them, and a status that quotes a database's raw message must never stop
/// the service that publishes it (issue 48).
inline std::string DumpText(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace mlp::base::json_fields
