#pragma once
/// @file The macro side's door: a local (Unix-domain) stream socket taking one request per
/// connection, a JSON object on one line, and answering with one JSON line (docs/HOSTD.md).
///
/// Work is bounded against a hostile or broken client (docs/HOSTD.md, "Limits"): open
/// connections are capped, a client has a deadline to send its line and to take its reply, a
/// request is at most kMaxRequestBytes and kMaxRequestDepth deep, and an accept that fails
/// (no file descriptors left) is retried, so the socket recovers when the load goes.
///
/// Requests run in lanes so that nobody waits behind a busy machine: `status` and other quick
/// ops on a small pool of their own; each machine's jobs in that machine's lane (one running,
/// a few waiting: more are refused at once as busy). A lane is named by the request's
/// "machine"; a request naming no known lane runs with the quick ops (its handler says what is
/// wrong). Malformed requests get {"ok": false, "error": ...}; the server keeps serving.

#include <chrono>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace mlp::service {

using Log = std::function<void(const std::string& line)>;
using Handler = std::function<nlohmann::json(const nlohmann::json& request)>;

struct JobServerLimits {
  /// Connections open at once. A connection beyond them closes the oldest one that has sent no
  /// request yet; when every one has, it is answered "too many connections".
  std::size_t max_connections = 64;
  /// From the connection to its request line, and from the reply ready to it taken: a client
  /// that trickles bytes or never reads is cut off after this.
  std::chrono::milliseconds client_timeout{10000};
  /// Jobs of one machine waiting behind its running one; more are refused at once as busy.
  std::size_t lane_waiting = 4;
  /// Threads answering the quick ops (status, and requests that fail before any work).
  int quick_workers = 2;
};

/// The job socket could not be opened (in use by a live host, not a socket, no permission).
class JobServerError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class JobServer {
 public:
  explicit JobServer(std::string socket_path, Log log, JobServerLimits limits = {});
  ~JobServer();
  /// Before Start: the handler of requests whose "op" is `op`, run on the quick pool (it must
  /// not block on a machine). A handler's exception becomes {"ok": false, "error": what()}.
  void Handle(const std::string& op, Handler handler);
  /// Before Start: the handler of a machine's op, run in the lane the request's "machine" names.
  void HandleInLane(const std::string& op, Handler handler);
  /// Before Start: a lane (a machine).
  void AddLane(const std::string& name);
  /// Binds the socket (mode 0660). A stale socket left by a crashed host is replaced; a live
  /// one, or a path that is not a socket, is not: throws JobServerError naming the path.
  void Start();
  /// Stops accepting, lets running handlers finish, removes the socket file.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mlp::service
