// The probe's side of a job over real loopback sockets: the virtual probe (rendered frames, the
// real firmware, the real link) answers the host's capture requests; bad requests and a full
// buffer are answered with typed errors and a status the host sees; replayed sessions and
// altered frames written straight onto the socket are rejected; several virtual probes stream
// to one host at once in bounded memory.

#include "mlp/link/transport.h"
#include "mlp/probe_fw/agent.h"
#include "mlp/sim/render.h"
#include "mlp/sim/virtual_camera.h"

#include <atomic>
#include <cmath>
#include <condition_variable>
#include <map>
#include <mutex>
#include <thread>
#include <utility>  // before Asio (Boost 1.74's awaitable.hpp needs std::exchange)

#include "link_test_util.h"
#include "virtual_probe_node.h"
#include <boost/asio.hpp>
#include <gtest/gtest.h>
#include <malloc.h>

namespace mlp::link {
namespace {

using namespace testing;

namespace asio = boost::asio;
using asio::ip::tcp;
using namespace std::chrono_literals;

constexpr auto kWait = 60s;
constexpr Millis kIdle = 2000ms;  // rendering runs beside the links: longer than 1 s // any single
                                  // expected event, at most
constexpr double kTopFaceRmsMm = 0.005;  // firmware points on a flat face, z in the MCS
constexpr double kTopFaceMaxMm = 0.020;

// z of every point in the MCS: the top face is z = 0.
void ExpectOnTopFace(const sim::VirtualProbe& probe, const LinkCloud& cloud) {
  const geometry::Pose3 mcs_from_probe = cloud.mcs_from_flange * probe.scene().flange_from_probe;
  double sum2 = 0.0, worst = 0.0;
  for (size_t i = 0; i < cloud.size(); ++i) {
    const geometry::Vec3 p(cloud.xyz[3 * i], cloud.xyz[3 * i + 1], cloud.xyz[3 * i + 2]);
    const double z = (mcs_from_probe * p).z();
    sum2 += z * z, worst = std::max(worst, std::abs(z));
  }
  const double rms = std::sqrt(sum2 / static_cast<double>(cloud.size()));
  std::printf("%zu points on the top face: z RMS %.2f um, max %.2f um\n", cloud.size(), rms * 1e3,
              worst * 1e3);
  EXPECT_LT(rms, kTopFaceRmsMm);
  EXPECT_LT(worst, kTopFaceMaxMm);
}

// What the host saw: clouds, errors and statuses, with a wait for a condition.
struct HostInbox : LogBook {
  // m (LogBook's) guards everything here
  std::condition_variable cv;
  std::map<std::string, LinkCloud> clouds;
  std::vector<ProbeError> errors;

  template <class Pred>
  bool WaitFor(Pred pred) {
    std::unique_lock lock(m);
    return cv.wait_for(lock, kWait, [&] { return pred(); });
  }
  void Cloud(const LinkCloud& c) {
    std::lock_guard lock(m);
    clouds[c.capture_id] = c;
    cv.notify_all();
  }
  void Error(const ProbeError& e) {
    std::lock_guard lock(m);
    errors.push_back(e);
    cv.notify_all();
  }
};

TEST(ProbeAgent, VirtualProbeAnswersCaptureRequestsAndBadRequestsGetTypedErrors) {
  HostInbox in;
  HostLink host(
      HostConfig({{"VP-1", KeyOf(1)}}, kIdle), [&](const LinkCloud& c) { in.Cloud(c); },
      [&](const std::string& l) { in.Log(l); });
  host.OnError([&](const std::string&, const ProbeError& e) { in.Error(e); });
  EXPECT_FALSE(host.RequestCapture("VP-1", TopRequest(*BoxProbe("VP-1"), "early", 0)));  // no probe
  host.Start();
  VirtualProbeNode node(BoxProbe("VP-1"), ProbeConfig("VP-1", KeyOf(1), host.Port(), kIdle));
  ASSERT_TRUE(WaitConnected(host, "VP-1"));

  const CaptureRequest top = TopRequest(*node.probe, "top-1", 0.0);
  ASSERT_TRUE(host.RequestCapture("VP-1", top));
  ASSERT_TRUE(in.WaitFor([&] { return in.clouds.count("top-1") > 0; }));
  {
    std::lock_guard lock(in.m);
    const LinkCloud& c = in.clouds.at("top-1");
    EXPECT_EQ(c.probe_serial, "VP-1");
    EXPECT_EQ(c.calibration_id, node.probe->model().calibration_id);
    EXPECT_TRUE(c.mcs_from_flange.matrix() == top.mcs_from_flange.matrix());
    EXPECT_LE(c.first_frame_ns, c.last_frame_ns);
    EXPECT_LE(c.last_frame_ns, c.processed_ns);
    EXPECT_GT(c.size(), 5000u);
    ExpectOnTopFace(*node.probe, c);
  }

  CaptureRequest no_hole = TopRequest(*node.probe, "no-hole", 0.0);
  no_hole.roi = "hole:1024,768";  // a flat face: there is no hole to find
  CaptureRequest off_sensor = TopRequest(*node.probe, "off-sensor", 0.0);
  off_sensor.aoi_x0 = 60000;
  CaptureRequest bad_roi = TopRequest(*node.probe, "bad-roi", 0.0);
  bad_roi.roi = "circle";
  for (const auto& r : {no_hole, off_sensor, bad_roi}) ASSERT_TRUE(host.RequestCapture("VP-1", r));
  ASSERT_TRUE(in.WaitFor([&] { return in.errors.size() >= 3; }));
  {
    std::lock_guard lock(in.m);
    std::set<std::string> ids;
    for (const ProbeError& e : in.errors) {
      EXPECT_EQ(e.code, ProbeErrorCode::kBadRequest) << e.message;
      EXPECT_FALSE(e.message.empty());
      ids.insert(e.capture_id);
    }
    EXPECT_EQ(ids, (std::set<std::string>{"no-hole", "off-sensor", "bad-roi"}));
  }
  EXPECT_TRUE(in.Logged("bad_request for capture no-hole"));
  // The probe keeps serving after refusing.
  ASSERT_TRUE(host.RequestCapture("VP-1", TopRequest(*node.probe, "top-2", 3.0)));
  ASSERT_TRUE(in.WaitFor([&] { return in.clouds.count("top-2") > 0; }));
  const auto status = host.LatestStatus("VP-1");
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(status->battery_percent, 87);
  EXPECT_EQ(status->temperature_c, 36.5);
  EXPECT_EQ(node.agent.Stats().failed, 3u);
  EXPECT_EQ(in.clouds.size(), 2u);
}

// One end of a connection driven by hand: frames written and read as they are on the wire.
class RawPeer {
 public:
  explicit RawPeer(tcp::socket s) : socket_(std::move(s)) {
    // Bounded reads: a missing frame fails the test instead of hanging it.
    const timeval limit{10, 0};
    setsockopt(socket_.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  }
  void Write(const Bytes& wire) {
    asio::write(socket_, asio::buffer(wire));
    sent_.insert(sent_.end(), wire.begin(), wire.end());
  }
  void Write(const Frame& f) { Write(Serialize(f)); }
  Frame Read() {
    Frame f;
    std::array<std::uint8_t, 16384> buf{};
    while (!parser_.Next(&f)) {
      const std::size_t n = socket_.read_some(asio::buffer(buf));
      parser_.Feed(buf.data(), n);
    }
    return f;
  }
  // Reads until the peer closes (true) or 10 s pass (false).
  bool ClosedByPeer() {
    std::array<std::uint8_t, 4096> buf{};
    boost::system::error_code ec;
    while (!ec) socket_.read_some(asio::buffer(buf), ec);
    return ec == asio::error::eof || ec == asio::error::connection_reset;
  }
  const Bytes& sent() const { return sent_; }

 private:
  tcp::socket socket_;
  Parser parser_;
  Bytes sent_;
};

TEST(ProbeAgent, FullBufferRefusesCapturesAndTheHostSeesItInStatus) {
  // A host driven by hand, which acknowledges only when told: the probe's buffer fills.
  asio::io_context io;
  tcp::acceptor acceptor(io, tcp::endpoint(asio::ip::make_address("127.0.0.1"), 0));
  ProbeLinkConfig cfg = ProbeConfig("VP-2", KeyOf(2), acceptor.local_endpoint().port());
  cfg.buffer_clouds = 2;
  cfg.idle_timeout = 20000ms;  // the hand-driven host sends no heartbeats
  VirtualProbeNode node(BoxProbe("VP-2"), cfg);
  RawPeer host(acceptor.accept());
  HostHandshake hs([](const std::string& s) -> std::optional<Key> {
    if (s == "VP-2") return KeyOf(2);
    return std::nullopt;
  });
  host.Write(hs.OnHello(host.Read()));
  hs.OnAuth(host.Read());
  Session session = hs.TakeSession();

  for (const char* id : {"a", "b", "c"})
    host.Write(
        session.Seal(MessageType::kCaptureRequest, Encode(TopRequest(*node.probe, id, 0, 64))));
  std::set<std::string> clouds;
  std::optional<ProbeError> refusal;
  bool saw_full = false;
  while (clouds.size() < 2 || !refusal || !saw_full) {
    const Frame f = host.Read();
    session.Open(f);
    if (f.type == MessageType::kCloud) clouds.insert(DecodeCloud(f.payload).capture_id);
    if (f.type == MessageType::kError) refusal = DecodeError(f.payload);
    if (f.type == MessageType::kStatus) {
      const ProbeStatus s = DecodeStatus(f.payload);
      if (s.flags & kStatusBufferFull) {
        EXPECT_EQ(s.buffer_used, 2u);
        EXPECT_EQ(s.buffer_capacity, 2u);
        saw_full = true;
      }
    }
  }
  EXPECT_EQ(clouds, (std::set<std::string>{"a", "b"}));   // the old clouds are kept ...
  EXPECT_EQ(refusal->code, ProbeErrorCode::kBufferFull);  // ... and the new capture refused
  EXPECT_EQ(refusal->capture_id, "c");
  EXPECT_EQ(node.link.Unacknowledged(), 2u);

  // One acknowledgement frees a place: the probe says so, and captures again.
  host.Write(session.Seal(MessageType::kAck, EncodeAck("a")));
  while (true) {
    const Frame f = host.Read();
    session.Open(f);
    if (f.type != MessageType::kStatus) continue;
    const ProbeStatus s = DecodeStatus(f.payload);
    if (s.buffer_used == 1 && !(s.flags & kStatusBufferFull)) break;
  }
  host.Write(
      session.Seal(MessageType::kCaptureRequest, Encode(TopRequest(*node.probe, "d", 0, 64))));
  while (true) {
    const Frame f = host.Read();
    session.Open(f);
    if (f.type == MessageType::kCloud && DecodeCloud(f.payload).capture_id == "d") break;
  }
  EXPECT_EQ(node.agent.Stats().captures, 3u);
}

LinkCloud SmallCloud(const std::string& serial, const std::string& id) {
  LinkCloud c;
  c.capture_id = id;
  c.probe_serial = serial;
  c.calibration_id = "cal";
  c.mcs_from_flange = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 100; ++i) {
    c.xyz.insert(c.xyz.end(), {i * 0.1, i * 0.2, 1.0});
    c.quality.push_back(0.5f);
  }
  return c;
}

// A probe driven by hand: handshake on the raw socket, then the session.
struct RawProbe {
  RawProbe(asio::io_context& io, std::uint16_t port, const std::string& serial, const Key& key)
      : peer([&] {
          tcp::socket s(io);
          s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
          return s;
        }()) {
    ProbeHandshake hs(serial, key);
    peer.Write(hs.Hello());
    peer.Write(hs.OnChallenge(peer.Read()));
    session = hs.TakeSession();
  }
  RawPeer peer;
  Session session;
};

TEST(ProbeAgent, ReplayedSessionsAndAlteredFramesOnTheSocketAreRejected) {
  HostInbox in;
  HostLink host(
      HostConfig({{"VP-3", KeyOf(3)}}, kIdle), [&](const LinkCloud& c) { in.Cloud(c); },
      [&](const std::string& l) { in.Log(l); });
  host.Start();
  asio::io_context io;
  Bytes recorded;
  {  // an honest session, recorded byte for byte as an eavesdropper on the Wi-Fi would
    RawProbe p(io, host.Port(), "VP-3", KeyOf(3));
    p.peer.Write(p.session.Seal(MessageType::kCloud, EncodeCloud(SmallCloud("VP-3", "c-1"), true)));
    Frame ack;
    do {
      ack = p.peer.Read();
      p.session.Open(ack);
    } while (ack.type != MessageType::kAck);
    EXPECT_EQ(DecodeAck(ack.payload), "c-1");
    recorded = p.peer.sent();
  }
  {  // the whole session replayed on a new connection: the host's new nonce defeats it
    tcp::socket s(io);
    s.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), host.Port()));
    RawPeer replay(std::move(s));
    replay.Write(recorded);
    EXPECT_TRUE(replay.ClosedByPeer());
  }
  {  // a frame replayed inside a live session: the sequence number gives it away
    RawProbe p(io, host.Port(), "VP-3", KeyOf(3));
    const Bytes wire = Serialize(
        p.session.Seal(MessageType::kCloud, EncodeCloud(SmallCloud("VP-3", "c-2"), true)));
    p.peer.Write(wire);
    p.peer.Write(wire);
    EXPECT_TRUE(p.peer.ClosedByPeer());
  }
  {  // a frame altered in flight, its CRC made right again: only the tag catches it
    RawProbe p(io, host.Port(), "VP-3", KeyOf(3));
    Frame f = p.session.Seal(MessageType::kCloud, EncodeCloud(SmallCloud("VP-3", "c-3"), true));
    f.payload[f.payload.size() / 2] ^= 0x01;
    p.peer.Write(Serialize(f));
    EXPECT_TRUE(p.peer.ClosedByPeer());
  }
  host.Stop();
  EXPECT_TRUE(in.Logged("auth_failed"));
  EXPECT_TRUE(in.Logged("replay"));
  EXPECT_TRUE(in.Logged("bad_tag"));
  const HostLinkStats stats = host.Stats();
  EXPECT_EQ(stats.delivered, 2u);   // c-1 once, c-2 once; c-3 never
  EXPECT_EQ(stats.duplicates, 0u);  // the replayed session never reached the cloud
  EXPECT_EQ(stats.rejected, 3u);
  EXPECT_EQ(in.clouds.count("c-3"), 0u);
}

// Heap bytes in use by this process, all malloc arenas and mmapped blocks (glibc). Not the
// resident set: with seven threads, glibc's per-thread arenas keep freed pages resident in
// amounts that depend on scheduling (0 to 10 MiB across runs), which says nothing of a leak.
std::size_t HeapBytesInUse() {
  const struct mallinfo2 mi = mallinfo2();
  return mi.uordblks + mi.hblkhd;
}

TEST(ProbeAgent, SeveralVirtualProbesStreamToOneHostWithoutLossInBoundedMemory) {
  constexpr int kProbes = 3, kRounds = 20, kWarmUpRounds = 2;
  // The host keeps no cloud (a count only), so the heap must not grow with the
  // clouds streamed: a leak of every cloud (~0.35 MiB each) would exceed the bound twice over.
  constexpr double kHeapGrowthBoundMiB = 8.0;
  std::mutex m;
  std::map<std::string, std::size_t> points_received;
  std::atomic<std::size_t> bytes_received{0};
  std::map<std::string, Key> keys;
  for (int p = 0; p < kProbes; ++p)
    keys["VP-" + std::to_string(10 + p)] = KeyOf(static_cast<std::uint8_t>(10 + p));
  std::condition_variable cv;
  HostLink host(
      HostConfig(keys, kIdle),
      [&](const LinkCloud& c) {
        std::lock_guard lock(m);
        points_received[c.capture_id] = c.size();
        bytes_received += c.xyz.size() * sizeof(double);
        cv.notify_all();
      },
      [](const std::string&) {});
  host.Start();
  std::vector<std::unique_ptr<VirtualProbeNode>> nodes;
  for (const auto& [serial, key] : keys) {
    nodes.push_back(std::make_unique<VirtualProbeNode>(
        BoxProbe(serial), ProbeConfig(serial, key, host.Port(), kIdle)));
  }
  for (const auto& [serial, key] : keys) ASSERT_TRUE(WaitConnected(host, serial));
  std::size_t heap_after_warm_up = 0;
  for (int round = 0; round < kRounds; ++round) {
    for (int p = 0; p < kProbes; ++p) {
      const std::string serial = "VP-" + std::to_string(10 + p);
      const std::string id = serial + "/" + std::to_string(round);
      ASSERT_TRUE(host.RequestCapture(serial, TopRequest(*nodes[p]->probe, id, round * 0.5, 256)));
    }
    std::unique_lock lock(m);
    ASSERT_TRUE(cv.wait_for(lock, kWait, [&] {
      return points_received.size() == static_cast<size_t>(kProbes * (round + 1));
    }));
    if (round == kWarmUpRounds - 1) heap_after_warm_up = HeapBytesInUse();
  }
  const double growth_mib =
      (static_cast<double>(HeapBytesInUse()) - static_cast<double>(heap_after_warm_up)) / (1 << 20);
  const double streamed_mib = static_cast<double>(bytes_received) / (1 << 20);
  std::printf("streamed %.1f MiB of coordinates from %d probes; heap growth %.2f MiB\n",
              streamed_mib, kProbes, growth_mib);
  std::size_t points_sent = 0, points_got = 0;
  for (const auto& n : nodes) points_sent += n->agent.Stats().points;
  for (const auto& [id, n] : points_received) points_got += n;
  EXPECT_EQ(points_got, points_sent);  // no point lost on the way
  EXPECT_EQ(host.Stats().duplicates, 0u);
  EXPECT_LT(growth_mib, kHeapGrowthBoundMiB);
  EXPECT_GT(streamed_mib, 2 * kHeapGrowthBoundMiB);  // the bound means something
}

}  // namespace
}  // namespace mlp::link
