#pragma once
/// @file The client of mlp-hostd's job socket (what `mlp` uses): light, so that a macro's call
/// does not wait for libraries it does not need.

#include <string>

#include <nlohmann/json.hpp>

namespace mlp::service {

/// The client: sends `request`, waits at most `timeout_ms` for the reply. Throws
/// std::runtime_error when the host is not running (no socket, refused), on timeout or on a
/// reply that is not JSON.
nlohmann::json SendRequest(const std::string& socket_path,
                           const nlohmann::json& request,
                           int timeout_ms);

}  // namespace mlp::service
