#include "mlp/service/job_server.h"

#include <atomic>
#include <chrono>
#include <filesystem>
#include <map>
#include <mutex>
#include <thread>
#include <utility>  // before Asio (Boost 1.74 needs std::exchange)

#include <boost/asio.hpp>
#include <sys/stat.h>

namespace mlp::service {
namespace {

namespace asio = boost::asio;
using local = asio::local::stream_protocol;
using json = nlohmann::json;
// A request is a small JSON object; anything longer is not one.
constexpr std::size_t kMaxRequestBytes = 1 << 20;

json Error(const std::string& what) { return {{"ok", false}, {"error", what}}; }

// A socket file nobody listens on (a crashed host's) may be replaced; a live one may not.
bool SomeoneListens(const std::string& path) {
  asio::io_context io;
  local::socket s(io);
  boost::system::error_code ec;
  s.connect(local::endpoint(path), ec);
  return !ec;
}

}  // namespace

struct JobServer::Impl {
  std::string path;
  Log log;
  std::map<std::string, Handler> handlers;
  asio::io_context io;
  local::acceptor acceptor{io};
  asio::thread_pool workers;
  std::thread io_thread;
  std::atomic<bool> running{false};

  Impl(std::string p, Log l, int n) : path(std::move(p)), log(std::move(l)), workers(n) {}

  json Dispatch(const std::string& line) {
    json request;
    try {
      request = json::parse(line);
    } catch (const json::parse_error& e) {
      return Error(std::string("the request is not JSON: ") + e.what());
    }
    if (!request.is_object() || !request.contains("op") || !request.at("op").is_string())
      return Error("the request must be a JSON object with an \"op\"");
    const auto it = handlers.find(request.at("op").get<std::string>());
    if (it == handlers.end())
      return Error("unknown op \"" + request.at("op").get<std::string>() + "\"");
    try {
      return it->second(request);
    } catch (const std::exception& e) {
      return Error(e.what());
    }
  }

  void Serve(std::shared_ptr<local::socket> socket) {
    auto buffer = std::make_shared<asio::streambuf>(kMaxRequestBytes);
    asio::async_read_until(*socket, *buffer, '\n',
                           [this, socket, buffer](boost::system::error_code ec, std::size_t n) {
                             if (ec) {
                               log("job socket: request not read (" + ec.message() + ")");
                               return;
                             }
                             std::string line(
                                 asio::buffers_begin(buffer->data()),
                                 asio::buffers_begin(buffer->data()) + static_cast<long>(n));
                             // The handler may block for a capture: off the I/O thread.
                             asio::post(workers, [this, socket, line = std::move(line)] {
                               const std::string reply = Dispatch(line).dump() + "\n";
                               boost::system::error_code wec;
                               asio::write(*socket, asio::buffer(reply), wec);
                               if (wec)
                                 log("job socket: reply not delivered (" + wec.message() + ")");
                             });
                           });
  }

  void Accept() {
    acceptor.async_accept([this](boost::system::error_code ec, local::socket s) {
      if (ec) {
        if (running) log("job socket: accept failed (" + ec.message() + ")");
        return;
      }
      Serve(std::make_shared<local::socket>(std::move(s)));
      Accept();
    });
  }
};

JobServer::JobServer(std::string socket_path, Log log, int workers)
    : impl_(std::make_unique<Impl>(std::move(socket_path), std::move(log), workers)) {}

JobServer::~JobServer() { Stop(); }

void JobServer::Handle(const std::string& op, Handler handler) {
  impl_->handlers[op] = std::move(handler);
}

void JobServer::Start() {
  Impl& s = *impl_;
  if (std::filesystem::exists(s.path)) {
    if (SomeoneListens(s.path))
      throw std::runtime_error("job socket " + s.path +
                               " is in use: is mlp-hostd running already?");
    std::filesystem::remove(s.path);
    s.log("job socket: replaced the stale " + s.path);
  }
  std::filesystem::create_directories(std::filesystem::path(s.path).parent_path());
  s.acceptor.open();
  s.acceptor.bind(local::endpoint(s.path));
  ::chmod(s.path.c_str(), 0660);  // the NC machine's user and the host's group
  s.acceptor.listen();
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
  });
  s.workers.join();  // running jobs finish and reply
  s.io.stop();
  if (s.io_thread.joinable()) s.io_thread.join();
  std::error_code ec;
  std::filesystem::remove(s.path, ec);
}

}  // namespace mlp::service
