// The local job socket as a macro's client sees it: real Unix-domain sockets, one JSON request
// and one JSON reply per connection; a status query answered while a job is busy; bad requests
// answered with the reason; a live socket never taken over, a stale one replaced.

#include "mlp/service/job_server.h"

#include "mlp/service/job_client.h"

#include <chrono>
#include <filesystem>
#include <future>
#include <thread>
#include <utility>  // before Asio (Boost 1.74 needs std::exchange)

#include <boost/asio.hpp>
#include <gtest/gtest.h>

namespace mlp::service {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace std::chrono_literals;

constexpr int kReplyTimeoutMs = 10000;

std::string SocketPath(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / "mlp_job_server_test";
  fs::create_directories(dir);
  fs::remove(dir / name);
  return (dir / name).string();
}

// Raw bytes in, the reply line out: for requests the client would never send.
std::string RawExchange(const std::string& path, const std::string& bytes) {
  boost::asio::io_context io;
  boost::asio::local::stream_protocol::socket s(io);
  s.connect(boost::asio::local::stream_protocol::endpoint(path));
  boost::asio::write(s, boost::asio::buffer(bytes));
  boost::asio::streambuf b;
  boost::asio::read_until(s, b, '\n');
  return {boost::asio::buffers_begin(b.data()), boost::asio::buffers_end(b.data())};
}

TEST(JobServer, AnswersStatusWhileAJobIsBusy) {
  const std::string path = SocketPath("busy.sock");
  JobServer server(path, [](const std::string&) {});
  std::promise<void> release, entered;
  auto released = release.get_future().share();
  server.Handle("status", [](const json&) { return json{{"ok", true}, {"state", "idle"}}; });
  server.Handle("job", [released, &entered](const json& r) {
    entered.set_value();
    released.wait();  // a job waiting for its capture
    return json{{"ok", true}, {"machine", r.at("machine")}};
  });
  server.Start();
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                fs::perms::group_write);
  auto job = std::async(std::launch::async, [&] {
    return SendRequest(path, {{"op", "job"}, {"machine", "vmc-1"}}, kReplyTimeoutMs);
  });
  entered.get_future().wait();  // the job holds its handler now
  EXPECT_EQ(SendRequest(path, {{"op", "status"}}, kReplyTimeoutMs).at("state"), "idle");
  release.set_value();
  EXPECT_EQ(job.get().at("machine"), "vmc-1");
  server.Stop();
  EXPECT_FALSE(fs::exists(path));
}

TEST(JobServer, BadRequestsGetTheReason) {
  const std::string path = SocketPath("bad.sock");
  JobServer server(path, [](const std::string&) {});
  server.Handle("fail",
                [](const json&) -> json { throw std::runtime_error("calibration missing"); });
  server.Start();
  EXPECT_NE(RawExchange(path, "this is not json\n").find("not JSON"), std::string::npos);
  EXPECT_NE(RawExchange(path, "[1, 2]\n").find("with an \\\"op\\\""), std::string::npos);
  const json unknown = SendRequest(path, {{"op", "frobnicate"}}, kReplyTimeoutMs);
  EXPECT_EQ(unknown.at("ok"), false);
  EXPECT_EQ(unknown.at("error"), "unknown op \"frobnicate\"");
  const json failed = SendRequest(path, {{"op", "fail"}}, kReplyTimeoutMs);
  EXPECT_EQ(failed.at("error"), "calibration missing");
  server.Stop();
}

TEST(JobServer, ALiveSocketIsNeverTakenOverAStaleOneIsReplaced) {
  const std::string path = SocketPath("live.sock");
  JobServer first(path, [](const std::string&) {});
  first.Handle("status", [](const json&) { return json{{"ok", true}, {"who", "first"}}; });
  first.Start();
  JobServer second(path, [](const std::string&) {});
  EXPECT_THROW(second.Start(), JobServerError);
  EXPECT_EQ(SendRequest(path, {{"op", "status"}}, kReplyTimeoutMs).at("who"), "first");
  first.Stop();
  // A crashed host leaves its socket file behind: bind it without listening.
  {
    boost::asio::io_context io;
    boost::asio::local::stream_protocol::acceptor a(io);
    a.open();
    a.bind(boost::asio::local::stream_protocol::endpoint(path));
  }
  ASSERT_TRUE(fs::exists(path));
  std::vector<std::string> log;
  JobServer third(path, [&](const std::string& l) { log.push_back(l); });
  third.Handle("status", [](const json&) { return json{{"ok", true}, {"who", "third"}}; });
  third.Start();
  EXPECT_EQ(SendRequest(path, {{"op", "status"}}, kReplyTimeoutMs).at("who"), "third");
  third.Stop();
  ASSERT_FALSE(log.empty());
  EXPECT_NE(log[0].find("stale"), std::string::npos);
}

TEST(JobServer, TheClientSaysWhenTheHostIsNotRunning) {
  try {
    SendRequest(SocketPath("nobody.sock"), {{"op", "status"}}, 1000);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("is it running?"), std::string::npos) << e.what();
  }
  // A host that takes too long: the client gives up after its timeout.
  const std::string path = SocketPath("slow.sock");
  JobServer server(path, [](const std::string&) {});
  std::promise<void> gave_up;
  auto client_gave_up = gave_up.get_future().share();
  server.Handle("slow", [client_gave_up](const json&) {
    client_gave_up.wait();  // answers only after the client has given up, however slow it is
    return json{{"ok", true}};
  });
  server.Start();
  EXPECT_THROW(SendRequest(path, {{"op", "slow"}}, 100), JobClientError);
  gave_up.set_value();
  server.Stop();
}

}  // namespace
}  // namespace mlp::service
