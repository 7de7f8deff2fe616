#pragma once
/// @file The client of mlp-hostd's job socket (what `mlp` uses): light, so that a macro's call
/// does not wait for libraries it does not need.

#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace mlp::service {

/// The host did not answer: not running (no socket, refused), too slow, or not in JSON.
class JobClientError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The client: sends `request`, waits at most `timeout_ms` for the reply. Throws
/// JobClientError when the host is not running (no socket, refused), on timeout or on a reply
/// that is not JSON.
nlohmann::json SendRequest(const std::string& socket_path,
                           const nlohmann::json& request,
                           int timeout_ms);

}  // namespace mlp::service
