#pragma once
/// @file The macro side's door: a local (Unix-domain) stream socket taking one request per
/// connection, a JSON object on one line, and answering with one JSON line (docs/HOSTD.md).
/// Handlers run on a worker pool, so a status query is answered while a job waits for its
/// capture. Malformed requests get {"ok": false, "error": ...}; the server keeps serving.

#include <functional>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

namespace mlp::service {

using Log = std::function<void(const std::string& line)>;
using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;

class JobServer {
 public:
  /// `workers`: requests handled at once (jobs of different machines run in parallel).
  JobServer(std::string socket_path, Log log, int workers = 4);
  ~JobServer();
  /// Before Start: the handler of requests whose "op" is `op`. A handler's exception becomes
  /// {"ok": false, "error": what()}.
  void Handle(const std::string& op, Handler handler);
  /// Binds the socket (mode 0660; a stale socket file left by a crashed host is replaced, a live
  /// one is not: throws std::runtime_error naming the path) and starts serving.
  void Start();
  /// Stops accepting, lets running handlers finish, removes the socket file.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::service
