#include "mlp/service/job_server.h"

#include "mlp/service/request_json.h"

#include <atomic>
#include <chrono>
#include <deque>
#include <filesystem>
#include <map>
#include <thread>
#include <utility>  // before Asio (Boost 1.74 needs std::exchange)

#include <boost/asio.hpp>
#include <sys/stat.h>

namespace mlp::service {
namespace {

namespace asio = boost::asio;
using local = asio::local::stream_protocol;
using json = nlohmann::json;
using namespace std::chrono_literals;

// An accept that failed (no file descriptors left) is tried again this often: the socket must
// come back by itself when the load goes (systemd never restarts a process that stays alive).
constexpr auto kAcceptRetry = 100ms;
// How long Stop waits for replies already on their way to their clients.
constexpr auto kStopDrain = 2s;

json Error(const std::string& what) { return {{"ok", false}, {"error", what}}; }

// A socket file nobody listens on (a crashed host's) may be replaced; a live one may not.
bool SomeoneListens(const std::string& path) {
  asio::io_context io;
  local::socket s(io);
  boost::system::error_code ec;
  s.connect(local::endpoint(path), ec);
  return !ec;
}

// Logs the first of a run of like events and then every 1000th, with the count: a flood of
// hostile connections must not become a flood of log lines.
class Throttled {
 public:
  bool Due() { return count_++ % 1000 == 0; }
  std::uint64_t Count() const { return count_; }

 private:
  std::atomic<std::uint64_t> count_{0};
};

}  // namespace

struct JobServer::Impl {
  // One client connection. Its count of open connections is kept by its lifetime.
  struct Conn {
    Conn(local::socket s, std::atomic<std::size_t>& open_count)
        : socket(std::move(s)), deadline(socket.get_executor()), open(open_count) {
      ++open;
    }
    ~Conn() { --open; }
    local::socket socket;
    asio::steady_timer deadline;
    // One byte more than a request may hold, so that an over-long line is told apart from a
    // line that fills the limit exactly.
    asio::streambuf buffer{kMaxRequestBytes + 1};
    std::atomic<std::size_t>& open;
    bool awaiting_request = true;  // io thread only: no request line read yet
  };
  struct Lane {
    explicit Lane(std::size_t threads) : pool(threads) {}
    asio::thread_pool pool;
    std::atomic<std::size_t> admitted{0};  // running and waiting
  };

  std::string path;
  Log log;
  JobServerLimits limits;
  // Before the io_context: connections it still holds when destroyed count themselves out.
  std::atomic<std::size_t> open{0};
  Throttled over_cap, unread, evicted;
  // Connections that have not sent their request line yet, oldest first (io thread only).
  std::deque<std::weak_ptr<Conn>> silent;
  std::map<std::string, Handler> quick_handlers, lane_handlers;
  std::map<std::string, std::unique_ptr<Lane>> lanes;
  asio::io_context io;
  // Keeps io.run() going while every connection waits in a lane (no I/O pending): replies
  // are posted to it afterwards.
  asio::executor_work_guard<asio::io_context::executor_type> keep_running{io.get_executor()};
  local::acceptor acceptor{io};
  asio::steady_timer accept_retry{io};
  asio::thread_pool quick;
  std::thread io_thread;
  std::atomic<bool> running{false};
  bool accept_failing = false;  // io thread only

  Impl(std::string p, Log l, JobServerLimits lim)
      : path(std::move(p)),
        log(std::move(l)),
        limits(lim),
        quick(static_cast<std::size_t>(std::max(1, lim.quick_workers))) {}

  json Run(const Handler& handler, const json& request) {
    try {
      return handler(request);
    } catch (const std::exception& e) {
      log("job socket: " + request.value("op", std::string("?")) + " request failed: " + e.what());
      return Error(e.what());
    }
  }

  // The reply goes out on the I/O thread, bounded by the client's deadline: a client that
  // never reads cannot hold a worker.
  void Respond(const std::shared_ptr<Conn>& c, const json& reply) {
    auto text = std::make_shared<std::string>(DumpSafe(reply) + "\n");
    asio::post(io, [this, c, text] {
      Arm(c);
      asio::async_write(c->socket, asio::buffer(*text),
                        [this, c, text](boost::system::error_code ec, std::size_t) {
                          if (ec) log("job socket: reply not delivered (" + ec.message() + ")");
                          c->deadline.cancel();
                          boost::system::error_code ignored;
                          c->socket.close(ignored);
                        });
    });
  }

  void Arm(const std::shared_ptr<Conn>& c) {
    c->deadline.expires_after(limits.client_timeout);
    c->deadline.async_wait([c](boost::system::error_code ec) {
      if (ec) return;  // cancelled: the exchange finished in time
      boost::system::error_code ignored;
      c->socket.close(ignored);
    });
  }

  // Where a parsed request runs: its machine's lane, or the quick pool.
  void Route(const std::shared_ptr<Conn>& c, const json& request) {
    const std::string op = request.contains("op") && request.at("op").is_string()
                               ? request.at("op").get<std::string>()
                               : std::string();
    if (op.empty()) return Respond(c, Error("the request must be a JSON object with an \"op\""));
    if (const auto q = quick_handlers.find(op); q != quick_handlers.end()) {
      return asio::post(quick,
                        [this, c, request, h = &q->second] { Respond(c, Run(*h, request)); });
    }
    const auto h = lane_handlers.find(op);
    if (h == lane_handlers.end()) return Respond(c, Error("unknown op \"" + op + "\""));
    const json& m = request.contains("machine") ? request.at("machine") : json();
    const auto lane = m.is_string() ? lanes.find(m.get<std::string>()) : lanes.end();
    if (lane == lanes.end())  // the handler names what is wrong, without blocking anything
      return asio::post(quick,
                        [this, c, request, h = &h->second] { Respond(c, Run(*h, request)); });
    Lane& l = *lane->second;
    if (l.admitted.fetch_add(1) >= 1 + limits.lane_waiting) {
      --l.admitted;
      return Respond(c, {{"ok", false},
                         {"status", "failed"},
                         {"error", "machine " + lane->first + " is busy: a job runs and " +
                                       std::to_string(limits.lane_waiting) +
                                       " wait already; send this one again later"}});
    }
    asio::post(l.pool, [this, c, request, h = &h->second, &l] {
      const json reply = Run(*h, request);
      --l.admitted;
      Respond(c, reply);
    });
  }

  void Serve(const std::shared_ptr<Conn>& c) {
    Arm(c);
    asio::async_read_until(
        c->socket, c->buffer, '\n', [this, c](boost::system::error_code ec, std::size_t n) {
          c->deadline.cancel();
          if (ec == asio::error::not_found)  // the buffer filled before a newline came
            return Respond(c, Error("the request is longer than " +
                                    std::to_string(kMaxRequestBytes) + " bytes: not read"));
          if (ec) {
            if (unread.Due())
              log("job socket: request not read (" + ec.message() + "; " +
                  std::to_string(unread.Count()) + " so far)");
            return;
          }
          const std::string line(asio::buffers_begin(c->buffer.data()),
                                 asio::buffers_begin(c->buffer.data()) + static_cast<long>(n));
          json request;
          try {
            request = ParseRequest(line);
          } catch (const RequestParseError& e) {
            return Respond(c, Error(e.what()));
          }
          Route(c, request);
        });
  }

  // Every client sends its request line at once (`mlp status` within a millisecond): a
  // connection that has sent nothing yet is the one to close when all are taken. 64 idle
  // connections renewed every 8 s used to make half of the `mlp status` calls fail.
  bool EvictSilent() {
    while (!silent.empty()) {
      const std::shared_ptr<Conn> oldest = silent.front().lock();
      silent.pop_front();
      if (!oldest || !oldest->awaiting_request || !oldest->socket.is_open()) continue;
      boost::system::error_code ignored;
      oldest->socket.close(ignored);
      return true;
    }
    return false;
  }

  void Accept() {
    acceptor.async_accept([this](boost::system::error_code ec, local::socket s) {
      if (!running || ec == asio::error::operation_aborted) return;
      if (ec) {
        // EMFILE / ENFILE: no descriptor for the new connection. It waits in the backlog;
        // try again shortly rather than never.
        if (!accept_failing) log("job socket: accept failed (" + ec.message() + "): retrying");
        accept_failing = true;
        accept_retry.expires_after(kAcceptRetry);
        accept_retry.async_wait([this](boost::system::error_code) { Accept(); });
        return;
      }
      if (accept_failing) log("job socket: accepting again");
      accept_failing = false;
      auto c = std::make_shared<Conn>(std::move(s), open);
      // The evicted one counts itself out once its read is cancelled: this one takes its place.
      const bool full = open > limits.max_connections;
      const bool made_room = full && EvictSilent();
      if (made_room && evicted.Due())
        log("job socket: " + std::to_string(limits.max_connections) +
            " connections open: closed the oldest that had sent no request (" +
            std::to_string(evicted.Count()) + " so far)");
      if (full && !made_room) {
        if (over_cap.Due())
          log("job socket: " + std::to_string(limits.max_connections) +
              " connections open: refused one (" + std::to_string(over_cap.Count()) + " so far)");
        Respond(c, Error("the host has " + std::to_string(limits.max_connections) +
                         " connections open: try again"));
      } else {
        std::erase_if(silent, [](const std::weak_ptr<Conn>& w) {
          const auto p = w.lock();
          return !p || !p->awaiting_request;
        });
        silent.push_back(c);
        Serve(c);
      }
      Accept();
    });
  }

  void Bind() {
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0) {
      if (!S_ISSOCK(st.st_mode))
        throw JobServerError("job socket " + path +
                             " exists and is not a socket: not replaced (check job_socket)");
      if (SomeoneListens(path))
        throw JobServerError("job socket " + path + " is in use: is mlp-hostd running already?");
      std::filesystem::remove(path);
      log("job socket: replaced the stale " + path);
    }
    try {
      std::filesystem::create_directories(std::filesystem::path(path).parent_path());
      acceptor.open();
      acceptor.bind(local::endpoint(path));
      ::chmod(path.c_str(), 0660);  // the NC machine's user and the host's group
      acceptor.listen();
    } catch (const std::exception& e) {
      throw JobServerError("cannot listen on the job socket " + path + ": " + e.what());
    }
  }
};

JobServer::JobServer(std::string socket_path, Log log, JobServerLimits limits)
    : impl_(std::make_unique<Impl>(std::move(socket_path), std::move(log), limits)) {}

JobServer::~JobServer() { Stop(); }

void JobServer::Handle(const std::string& op, Handler handler) {
  impl_->quick_handlers[op] = std::move(handler);
}

void JobServer::HandleInLane(const std::string& op, Handler handler) {
  impl_->lane_handlers[op] = std::move(handler);
}

void JobServer::AddLane(const std::string& name) {
  impl_->lanes.emplace(name, std::make_unique<Impl::Lane>(1 + impl_->limits.lane_waiting));
}

void JobServer::Start() {
  Impl& s = *impl_;
  s.Bind();
  s.running = true;
  s.Accept();
  s.io_thread = std::thread([&s] { s.io.run(); });
}

void JobServer::Stop() {
  Impl& s = *impl_;
  if (!s.running.exchange(false)) return;
  asio::post(s.io, [&s] {
    boost::system::error_code ec;
    s.acceptor.close(ec);
    s.accept_retry.cancel();
  });
  for (auto& [name, lane] : s.lanes) lane->pool.join();  // running jobs finish and reply
  s.quick.join();
  // Replies on their way get a moment to reach their clients.
  for (auto waited = 0ms; s.open > 0 && waited < kStopDrain; waited += 10ms)
    std::this_thread::sleep_for(10ms);
  s.io.stop();
  if (s.io_thread.joinable()) s.io_thread.join();
  std::error_code ec;
  std::filesystem::remove(s.path, ec);
}

}  // namespace mlp::service
