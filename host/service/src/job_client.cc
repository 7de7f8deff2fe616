#include "mlp/service/job_client.h"

#include "mlp/service/request_json.h"

#include <chrono>
#include <utility>  // before Asio (Boost 1.74 needs std::exchange)

#include <boost/asio.hpp>

namespace mlp::service {
namespace {

namespace asio = boost::asio;
using local = asio::local::stream_protocol;
using json = nlohmann::json;
// Replies carry results, not clouds: 16 MiB is far beyond any.
constexpr std::size_t kMaxReplyBytes = 16u << 20;

}  // namespace

json SendRequest(const std::string& socket_path, const json& request, int timeout_ms) {
  asio::io_context io;
  local::socket socket(io);
  boost::system::error_code ec;
  socket.connect(local::endpoint(socket_path), ec);
  if (ec)
    throw JobClientError("mlp-hostd is not answering on " + socket_path + " (" + ec.message() +
                         "): is it running?");
  asio::write(socket, asio::buffer(DumpSafe(request) + "\n"), ec);
  if (ec) throw JobClientError("cannot send the request: " + ec.message());
  asio::streambuf buffer(kMaxReplyBytes);
  bool done = false;
  std::size_t n = 0;
  asio::async_read_until(socket, buffer, '\n', [&](boost::system::error_code e, std::size_t k) {
    ec = e, n = k, done = true;
  });
  io.run_for(std::chrono::milliseconds(timeout_ms));
  if (!done)
    throw JobClientError("no reply from mlp-hostd within " + std::to_string(timeout_ms) + " ms");
  if (ec) throw JobClientError("the reply was not read: " + ec.message());
  const std::string line(asio::buffers_begin(buffer.data()),
                         asio::buffers_begin(buffer.data()) + static_cast<long>(n));
  try {
    return json::parse(line);
  } catch (const json::parse_error& e) {
    throw JobClientError(std::string("the reply is not JSON: ") + e.what());
  }
}

}  // namespace mlp::service
