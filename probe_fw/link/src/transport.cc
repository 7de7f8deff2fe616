// Boost 1.74's awaitable.hpp uses std::exchange without including <utility>.
#include "mlp/link/transport.h"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <future>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <unordered_set>
#include <utility>

#include <boost/asio.hpp>

namespace mlp::link {
namespace {

namespace asio = boost::asio;
using asio::awaitable;
using asio::use_awaitable;
using asio::ip::tcp;
using Clock = std::chrono::steady_clock;
// An accept that failed (no file descriptors left) is tried again this often.
constexpr Millis kAcceptRetry{100};

// Counts like events; Due() is true for the first and every 1000th: a flood of hostile
// connections must not become a flood of log lines.
class Throttled {
 public:
  bool Due() { return count_++ % 1000 == 0; }
  std::uint64_t Count() const { return count_; }

 private:
  std::uint64_t count_ = 0;
};

// One TCP connection: the socket, its parser, and the time of the last byte received.
struct Conn {
  explicit Conn(tcp::socket s) : socket(std::move(s)), wake(socket.get_executor()) {}
  // Frames are written whole: Nagle's algorithm would only hold small ACKs and heartbeats back
  // (measured: 66 ms instead of 21 ms for 20 clouds on loopback).
  void NoDelay() {
    boost::system::error_code ignored;
    socket.set_option(tcp::no_delay(true), ignored);
  }
  tcp::socket socket;
  asio::steady_timer wake;  // the writer sleeps on it; cancelled to wake it
  Parser parser;
  Clock::time_point last_rx = Clock::now();
  Millis idle{3000};  // the watchdog's limit: the handshake's, then the session's
  // The handshake's end, at the latest, whatever arrives meanwhile: a peer trickling a byte
  // now and then must not hold a connection (slow loris). Cleared once authenticated.
  Clock::time_point deadline = Clock::time_point::max();
  bool alive = true;
  std::deque<Bytes> outbox;  // serialized frames waiting for the writer

  void Close() {
    alive = false;
    boost::system::error_code ignored;
    socket.shutdown(tcp::socket::shutdown_both, ignored);
    socket.close(ignored);
    wake.cancel();
  }
  void Send(Bytes wire) {
    outbox.push_back(std::move(wire));
    wake.cancel();
  }
};

awaitable<Frame> ReadFrame(std::shared_ptr<Conn> c) {
  Frame f;
  std::uint8_t buf[16384];
  while (!c->parser.Next(&f)) {
    const std::size_t n = co_await c->socket.async_read_some(asio::buffer(buf), use_awaitable);
    c->last_rx = Clock::now();
    c->parser.Feed(buf, n);
  }
  co_return f;
}

// Frames and connections are taken by value: a coroutine must not hold references to its
// caller's objects across a suspension.
awaitable<void> WriteNow(std::shared_ptr<Conn> c, Frame f) {
  const Bytes wire = Serialize(f);
  co_await asio::async_write(c->socket, asio::buffer(wire), use_awaitable);
}

// Closes the connection when nothing arrives for `idle` (covers a peer that vanished without a
// FIN, which TCP alone notices only after minutes).
awaitable<void> Watchdog(std::shared_ptr<Conn> c) {
  asio::steady_timer t(c->socket.get_executor());
  while (c->alive) {
    t.expires_after(Millis(20));
    boost::system::error_code ec;
    co_await t.async_wait(asio::redirect_error(use_awaitable, ec));
    const auto now = Clock::now();
    if (now - c->last_rx > c->idle || now > c->deadline) c->Close();
  }
}

// Sends queued frames, and a heartbeat whenever the line has been quiet for `heartbeat`. Never
// throws: a failed write closes the connection.
awaitable<void> Writer(std::shared_ptr<Conn> c,
                       std::shared_ptr<Session> session,
                       Millis heartbeat,
                       std::function<void()> refill) {
  Clock::time_point last_tx = Clock::now();
  while (c->alive) {
    if (refill) refill();
    if (!c->outbox.empty()) {
      const Bytes wire = std::move(c->outbox.front());
      c->outbox.pop_front();
      boost::system::error_code ec;
      co_await asio::async_write(c->socket, asio::buffer(wire),
                                 asio::redirect_error(use_awaitable, ec));
      if (ec) break;
      last_tx = Clock::now();
      continue;
    }
    if (Clock::now() - last_tx >= heartbeat) {
      c->outbox.push_back(Serialize(session->Seal(MessageType::kHeartbeat, {})));
      continue;
    }
    c->wake.expires_at(last_tx + heartbeat);
    boost::system::error_code ec;
    co_await c->wake.async_wait(asio::redirect_error(use_awaitable, ec));
  }
  c->Close();
}

void SendSealed(Conn& c, Session& session, MessageType type, Bytes payload) {
  c.Send(Serialize(session.Seal(type, std::move(payload))));
}

}  // namespace

// ---------------------------------------------------------------- host

struct HostLink::Impl {
  HostLinkConfig cfg;
  CloudHandler on_cloud;
  StatusHandler on_status;
  ErrorHandler on_error;
  Admission admission;
  Log log;
  asio::io_context io;
  std::atomic<bool> running{false};
  std::optional<tcp::acceptor> acceptor;
  std::thread thread;
  mutable std::mutex stats_mutex;
  HostLinkStats stats;
  std::unordered_set<std::string> seen;
  std::deque<std::string> seen_order;
  std::size_t active = 0;                       // io thread only
  std::deque<std::weak_ptr<Conn>> handshaking;  // io thread only; oldest first
  Throttled refused, evicted, duplicate;
  // Per serial and reason: a capture asked of another probe must not hide behind a flood of
  // resends nobody waits for. Bounded: the serials are the configured ones, the reasons few.
  std::map<std::string, Throttled> unwanted;
  // The authenticated connection of each probe (io thread only); `names` and `statuses` mirror
  // what other threads may ask about.
  struct Registered {
    std::shared_ptr<Conn> conn;
    std::shared_ptr<Session> session;
  };
  std::map<std::string, Registered> connected;
  mutable std::mutex probes_mutex;
  std::set<std::string> names;
  std::map<std::string, ProbeStatus> statuses;
  // A probe that reconnects before its old connection timed out replaces it; but while the old
  // one is demonstrably alive (a frame within two heartbeats), the newcomer is refused: two
  // probes given one serial would otherwise throw each other out for ever.
  void Register(const std::string& serial, Registered r, const std::string& who) {
    const auto old = connected.find(serial);
    if (old != connected.end()) {
      Conn& was = *old->second.conn;
      if (was.alive && Clock::now() - was.last_rx < 2 * cfg.heartbeat) {
        if (duplicate.Due())
          SafeLog("link: " + who + " refused: probe " + serial +
                  " is connected and alive already (two probes with one serial? " +
                  std::to_string(duplicate.Count()) + " such refusals)");
        throw LinkError(LinkFault::kProtocol, "serial " + serial + " is connected already");
      }
      SafeLog("link: probe " + serial + " reconnected, its older connection is closed");
      was.Close();
    }
    connected[serial] = std::move(r);
    std::lock_guard lock(probes_mutex);
    names.insert(serial);
  }

  void Unregister(const std::string& serial, const std::shared_ptr<Conn>& c) {
    const auto it = connected.find(serial);
    if (it == connected.end() || it->second.conn != c) return;
    connected.erase(it);
    std::lock_guard lock(probes_mutex);
    names.erase(serial);
  }

  void Dispatch(const Frame& f, const std::string& serial, Conn& c, Session& session) {
    switch (f.type) {
      case MessageType::kCloud: {
        // The header first: nothing is decompressed for a cloud that is not wanted.
        const std::optional<CloudHeader> head = PeekOrReport(f.payload, serial);
        if (!head) {  // answered to its capture as malformed; the probe may drop it
          SendSealed(c, session, MessageType::kAck, EncodeAck(PeekCloudIds(f.payload).capture_id));
          return;
        }
        if (head->meta.probe_serial != serial)
          throw LinkError(LinkFault::kProtocol, "cloud of probe " + head->meta.probe_serial);
        // Seen per probe: another probe's key cannot spend this probe's capture id.
        const std::string key = serial + '\n' + head->meta.capture_id;
        if (seen.count(key) != 0) {
          Count(&HostLinkStats::duplicates);
        } else if (const std::string why = admission ? admission(serial, *head) : std::string();
                   !why.empty()) {
          Count(&HostLinkStats::unwanted);
          Throttled& t = unwanted[serial + '\n' + why];
          if (t.Due())
            SafeLog("link: cloud " + head->meta.capture_id + " of probe " + serial +
                    " not taken: " + why + " (" + std::to_string(t.Count()) + " such clouds)");
        } else {
          Remember(key);
          if (std::optional<LinkCloud> cloud = DecodeOrReport(f.payload, serial)) {
            on_cloud(*cloud);
            Count(&HostLinkStats::delivered);
          }
        }
        SendSealed(c, session, MessageType::kAck, EncodeAck(head->meta.capture_id));
        return;
      }
      case MessageType::kStatus: {
        const ProbeStatus status = DecodeStatus(f.payload);
        {
          std::lock_guard lock(probes_mutex);
          statuses[serial] = status;
        }
        if (on_status) on_status(serial, status);
        return;
      }
      case MessageType::kError: {
        const ProbeError error = DecodeError(f.payload);
        log("link: probe " + serial + " reports " + ToString(error.code) +
            (error.capture_id.empty() ? "" : " for capture " + error.capture_id) + ": " +
            error.message);
        if (on_error) on_error(serial, error);
        return;
      }
      case MessageType::kHeartbeat:
        return;
      default:
        throw LinkError(LinkFault::kProtocol,
                        "unexpected message type " + std::to_string(int(f.type)));
    }
  }

  // A cloud that is not one (issue 48 item 11: an edge of 0xFFFFFFFF points). Dropping the
  // session for it left the cloud in the probe's store-and-forward buffer, resent at every
  // reconnection: the probe never came back and its job waited out its timeout. Instead the
  // cloud is acknowledged (the probe drops it) and its capture answered with the reason;
  // nothing of it is delivered. Only a payload without even its capture id and serial, or of
  // another probe, still ends the session.
  std::optional<CloudHeader> PeekOrReport(const Bytes& payload, const std::string& serial) {
    try {
      return PeekCloud(payload);
    } catch (const LinkError& e) {
      if (e.fault() != LinkFault::kMalformedPayload) throw;
      const CloudIds ids = PeekCloudIds(payload);  // throws: not even those
      if (ids.probe_serial != serial)
        throw LinkError(LinkFault::kProtocol, "cloud of probe " + ids.probe_serial);
      Malformed(serial, ids.capture_id, e.what());
      return std::nullopt;
    }
  }

  std::optional<LinkCloud> DecodeOrReport(const Bytes& payload, const std::string& serial) {
    try {
      return DecodeCloud(payload);
    } catch (const LinkError& e) {
      if (e.fault() != LinkFault::kMalformedPayload) throw;
      Malformed(serial, PeekCloudIds(payload).capture_id, e.what());
      return std::nullopt;
    }
  }

  void Malformed(const std::string& serial, const std::string& capture_id, const char* what) {
    Count(&HostLinkStats::malformed);
    const ProbeError error{ProbeErrorCode::kCaptureFailed, capture_id,
                           std::string("the probe's cloud is malformed (") + what +
                               "): not measured; take the capture again, and have the probe's "
                               "firmware checked if it repeats"};
    Throttled& t = unwanted[serial + "\nmalformed"];  // a key's holder cannot flood the log
    if (t.Due())
      SafeLog("link: cloud " + capture_id + " of probe " + serial + ": " + error.message + " (" +
              std::to_string(t.Count()) + " such clouds)");
    if (on_error) on_error(serial, error);
  }

  void Count(std::uint64_t HostLinkStats::*field) {
    std::lock_guard lock(stats_mutex);
    ++(stats.*field);
  }

  // Remembers a delivered (serial, capture id); bounded: the oldest are forgotten.
  void Remember(const std::string& key) {
    if (!seen.insert(key).second) return;
    seen_order.push_back(key);
    if (seen_order.size() > cfg.remembered_captures)
      seen.erase(seen_order.front()), seen_order.pop_front();
  }

  // Never ends while the host runs: an accept that fails (no file descriptors left) is tried
  // again shortly, so the link comes back by itself when the load goes.
  awaitable<void> Accept() {
    bool failing = false;
    while (running) {
      boost::system::error_code ec;
      tcp::socket socket = co_await acceptor->async_accept(asio::redirect_error(use_awaitable, ec));
      if (ec == asio::error::operation_aborted) co_return;
      if (ec) {
        if (!failing) SafeLog("link: accept failed (" + ec.message() + "): retrying");
        failing = true;
        asio::steady_timer pause(io, kAcceptRetry);
        co_await pause.async_wait(asio::redirect_error(use_awaitable, ec));
        continue;
      }
      if (failing) SafeLog("link: accepting again");
      failing = false;
      Count(&HostLinkStats::connections);
      if (active >= cfg.max_connections) {
        if (refused.Due())
          SafeLog("link: refused a connection: " + std::to_string(active) +
                  " connections open already (" + std::to_string(refused.Count()) + " so far)");
        continue;  // the socket closes here
      }
      auto conn = std::make_shared<Conn>(std::move(socket));
      conn->NoDelay();
      AdmitHandshake(conn);
      asio::co_spawn(io, Serve(conn), asio::detached);
    }
  }

  // At most max_handshakes peers may be between connecting and authenticating; a new one
  // closes the oldest. An honest probe's handshake takes one round trip, so peers that
  // connect and say nothing cannot keep it out.
  void AdmitHandshake(const std::shared_ptr<Conn>& c) {
    std::erase_if(handshaking, [](const std::weak_ptr<Conn>& w) {
      const auto p = w.lock();
      return !p || !p->alive || p->deadline == Clock::time_point::max();
    });
    if (handshaking.size() >= cfg.max_handshakes) {
      if (const auto oldest = handshaking.front().lock()) oldest->Close();
      handshaking.pop_front();
      if (evicted.Due())
        SafeLog("link: " + std::to_string(cfg.max_handshakes) +
                " peers were still in their handshake: closed the oldest (" +
                std::to_string(evicted.Count()) + " so far)");
    }
    c->idle = cfg.handshake_timeout;
    c->deadline = Clock::now() + cfg.handshake_timeout;
    c->parser.SetMaxPayload(kMaxHandshakePayloadBytes);
    handshaking.push_back(c);
  }

  // A log line must never throw out of the link's thread (a handler that threw skipped the
  // clean-up that frees a connection slot).
  void SafeLog(const std::string& line) noexcept {
    try {
      log(line);
    } catch (...) {
    }
  }

  awaitable<void> Serve(std::shared_ptr<Conn> c) {
    ++active;
    std::string serial, from, who;
    try {
      boost::system::error_code ec;
      const auto remote = c->socket.remote_endpoint(ec);
      if (!ec) from = " from " + remote.address().to_string() + ":" + std::to_string(remote.port());
      who = "unauthenticated peer" + from;
      asio::co_spawn(io, Watchdog(c), asio::detached);
      HostHandshake hs([this](const std::string& claimed) -> std::optional<Key> {
        const auto it = cfg.probes.find(claimed);
        if (it == cfg.probes.end()) return std::nullopt;
        return it->second;
      });
      // One co_await per statement: GCC 12 mishandles temporaries of nested co_await expressions.
      const Frame hello = co_await ReadFrame(c);
      Frame challenge = hs.OnHello(hello);
      who = "peer claiming serial " + hs.serial() + from;
      co_await WriteNow(c, std::move(challenge));
      const Frame auth = co_await ReadFrame(c);
      hs.OnAuth(auth);
      who = "probe " + hs.serial() + from;
      Count(&HostLinkStats::authenticated);
      auto session = std::make_shared<Session>(hs.TakeSession());
      Register(hs.serial(), {c, session}, who);
      serial = hs.serial();
      c->idle = cfg.idle_timeout;
      c->deadline = Clock::time_point::max();
      c->parser.SetMaxPayload(kMaxPayloadBytes);
      std::function<void()> no_refill;
      asio::co_spawn(io, Writer(c, session, cfg.heartbeat, no_refill), asio::detached);
      while (c->alive) {
        const Frame f = co_await ReadFrame(c);
        session->Open(f);
        Dispatch(f, serial, *c, *session);
      }
    } catch (const LinkError& e) {
      Count(&HostLinkStats::rejected);
      SafeLog("link: rejected " + who + ": " + e.what());
    } catch (const std::exception& e) {
      SafeLog("link: " + who + " disconnected (" + e.what() + ")");
    } catch (...) {
      SafeLog("link: " + who + " disconnected");
    }
    // Reached however the connection ended (SafeLog never throws): the slot is given back. (A
    // destructor-based guard would be neater, but GCC 12 destroys coroutine locals twice when
    // an exception leaves a co_await: seen as a double free.)
    c->Close();
    if (!serial.empty()) Unregister(serial, c);
    --active;
  }
};

HostLink::HostLink(HostLinkConfig config, CloudHandler on_cloud, Log log)
    : impl_(std::make_unique<Impl>()) {
  impl_->cfg = std::move(config);
  impl_->on_cloud = std::move(on_cloud);
  impl_->log = std::move(log);
}

HostLink::~HostLink() { Stop(); }

void HostLink::OnStatus(StatusHandler handler) { impl_->on_status = std::move(handler); }
void HostLink::OnError(ErrorHandler handler) { impl_->on_error = std::move(handler); }
void HostLink::SetAdmission(Admission admission) { impl_->admission = std::move(admission); }

bool HostLink::RequestCapture(const std::string& serial, const CaptureRequest& request) {
  auto& d = *impl_;
  Bytes payload = Encode(request);  // throws here, in the caller's thread, if malformed
  if (!d.running) return false;
  auto sent = std::make_shared<std::promise<bool>>();
  std::future<bool> result = sent->get_future();
  asio::post(d.io, [&d, serial, sent, payload = std::move(payload)]() mutable {
    const auto it = d.connected.find(serial);
    if (it == d.connected.end() || !it->second.conn->alive) return sent->set_value(false);
    SendSealed(*it->second.conn, *it->second.session, MessageType::kCaptureRequest,
               std::move(payload));
    sent->set_value(true);
  });
  // Bounded: a host stopped meanwhile never runs the handler.
  constexpr Millis kPostTimeout{2000};
  return result.wait_for(kPostTimeout) == std::future_status::ready && result.get();
}

std::optional<ProbeStatus> HostLink::LatestStatus(const std::string& serial) const {
  std::lock_guard lock(impl_->probes_mutex);
  const auto it = impl_->statuses.find(serial);
  if (it == impl_->statuses.end()) return std::nullopt;
  return it->second;
}

std::vector<std::string> HostLink::ConnectedProbes() const {
  std::lock_guard lock(impl_->probes_mutex);
  return {impl_->names.begin(), impl_->names.end()};
}

void HostLink::Start() {
  auto& d = *impl_;
  try {
    const tcp::endpoint at(asio::ip::make_address(d.cfg.bind_address), d.cfg.port);
    d.acceptor.emplace(d.io, at);
  } catch (const std::exception& e) {
    throw LinkError(LinkFault::kLocal, "cannot listen on " + d.cfg.bind_address + ":" +
                                           std::to_string(d.cfg.port) + " (" + e.what() + ")");
  }
  asio::co_spawn(d.io, d.Accept(), asio::detached);
  d.running = true;
  d.thread = std::thread([&d] { d.io.run(); });
}

void HostLink::Stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->running = false;
  impl_->io.stop();
  impl_->thread.join();
}

std::uint16_t HostLink::Port() const {
  return impl_->acceptor ? impl_->acceptor->local_endpoint().port() : 0;
}

HostLinkStats HostLink::Stats() const {
  std::lock_guard lock(impl_->stats_mutex);
  return impl_->stats;
}

// ---------------------------------------------------------------- probe

struct ProbeLink::Impl {
  struct Pending {
    std::string capture_id;
    Bytes payload;
    std::uint64_t sent_on = 0;  // connection number it was last sent on
  };

  ProbeLinkConfig cfg;
  Log log;
  asio::io_context io;
  std::thread thread;
  mutable std::mutex m;
  mutable std::condition_variable acked;
  std::deque<Pending> store;
  std::uint64_t connection = 0;
  std::atomic<std::uint64_t> reconnects{0};
  std::shared_ptr<Conn> current;             // io thread only
  std::shared_ptr<Session> current_session;  // io thread only; null before authentication
  std::deque<CaptureRequest> requests;       // guarded by m
  std::condition_variable request_cv;
  std::function<ProbeStatus()> status_source;
  std::atomic<bool> status_due{true};
  Clock::time_point last_status{};  // io thread only

  ProbeStatus Status() {
    ProbeStatus s;
    if (status_source) s = status_source();
    std::lock_guard lock(m);
    s.buffer_used = static_cast<std::uint32_t>(store.size());
    s.buffer_capacity = static_cast<std::uint32_t>(cfg.buffer_clouds);
    s.flags = static_cast<std::uint8_t>(s.flags & ~kStatusBufferFull);
    if (store.size() >= cfg.buffer_clouds) s.flags |= kStatusBufferFull;
    return s;
  }

  // STATUS on a new session, every status_period, and when something of note changed.
  void MaybeSendStatus(Conn& c, Session& session) {
    const auto now = Clock::now();
    if (!status_due && now - last_status < cfg.status_period) return;
    status_due = false;
    last_status = now;
    try {
      SendSealed(c, session, MessageType::kStatus, Encode(Status()));
    } catch (const LinkError& e) {
      log(std::string("link: status not sent: ") + e.what());
    }
  }

  void SendError(Conn& c, Session& session, const ProbeError& e) {
    log("link: error to host: " + std::string(ToString(e.code)) + " " + e.capture_id + ": " +
        e.message);
    SendSealed(c, session, MessageType::kError, Encode(e));
  }

  // A capture request is queued for the firmware unless the link must refuse it.
  void OnRequest(Conn& c, Session& session, const Frame& f) {
    CaptureRequest r;
    try {
      r = DecodeCaptureRequest(f.payload);
    } catch (const LinkError& e) {
      return SendError(c, session, {ProbeErrorCode::kBadRequest, "", e.what()});
    }
    std::optional<ProbeError> refusal;
    {
      std::lock_guard lock(m);
      if (store.size() >= cfg.buffer_clouds) {
        refusal = ProbeError{ProbeErrorCode::kBufferFull, r.capture_id,
                             std::to_string(store.size()) +
                                 " clouds wait for the host's acknowledgement; capture refused"};
      } else if (requests.size() >= cfg.request_queue) {
        refusal = ProbeError{ProbeErrorCode::kBusy, r.capture_id,
                             std::to_string(requests.size()) + " requests wait already"};
      } else {
        requests.push_back(std::move(r));
        request_cv.notify_all();
      }
    }
    if (refusal) {
      SendError(c, session, *refusal);
      status_due = true;
    }
  }

  // Moves the next pending cloud not yet sent on this connection into the connection's outbox.
  void Refill(const std::shared_ptr<Conn>& c, Session* session, std::uint64_t number) {
    if (!c->alive) return;
    if (!c->outbox.empty()) return;
    std::lock_guard lock(m);
    for (Pending& p : store) {
      if (p.sent_on == number) continue;
      p.sent_on = number;
      c->outbox.push_back(Serialize(session->Seal(MessageType::kCloud, p.payload)));
      return;
    }
  }

  void Acknowledge(const Frame& f) {
    const std::string id = DecodeAck(f.payload);
    std::lock_guard lock(m);
    if (store.size() >= cfg.buffer_clouds) status_due = true;  // no longer full: say so
    for (auto it = store.begin(); it != store.end(); ++it) {
      if (it->capture_id == id) {
        store.erase(it);
        break;
      }
    }
    acked.notify_all();
  }

  awaitable<void> Connect(std::shared_ptr<Conn> c) {
    tcp::resolver resolver(io);
    const auto endpoints =
        co_await resolver.async_resolve(cfg.host, std::to_string(cfg.port), use_awaitable);
    asio::steady_timer timer(io, cfg.connect_timeout);
    timer.async_wait([c](const boost::system::error_code& ec) {
      if (!ec) c->Close();  // a connect that hangs is given up
    });
    co_await asio::async_connect(c->socket, endpoints, use_awaitable);
    timer.cancel();
  }

  awaitable<void> ReadLoop(std::shared_ptr<Conn> c, std::shared_ptr<Session> session) {
    try {
      while (c->alive) {
        const Frame f = co_await ReadFrame(c);
        session->Open(f);
        if (f.type == MessageType::kAck) {
          Acknowledge(f);
        } else if (f.type == MessageType::kCaptureRequest) {
          OnRequest(*c, *session, f);
        } else if (f.type != MessageType::kHeartbeat) {
          throw LinkError(LinkFault::kProtocol,
                          "unexpected message type " + std::to_string(int(f.type)));
        }
      }
    } catch (const std::exception& e) {
      log(std::string("link: connection lost (") + e.what() + ")");
    }
    c->Close();
  }

  awaitable<void> Run() {
    Millis backoff = cfg.backoff_min;
    while (true) {
      auto c = std::make_shared<Conn>(tcp::socket(io));
      current = c;
      try {
        co_await Connect(c);
        c->NoDelay();
        c->last_rx = Clock::now();
        c->idle = cfg.idle_timeout;
        c->parser.SetMaxPayload(kMaxHandshakePayloadBytes);  // until the host proved its key
        asio::co_spawn(io, Watchdog(c), asio::detached);
        ProbeHandshake hs(cfg.serial, cfg.key);
        // Named locals only around co_await inside this try block: GCC 12 destroys temporaries
        // of a co_await expression twice when an exception leaves it (seen under ASan).
        Frame hello = hs.Hello();
        co_await WriteNow(c, std::move(hello));
        const Frame challenge = co_await ReadFrame(c);
        Frame auth = hs.OnChallenge(challenge);
        co_await WriteNow(c, std::move(auth));
        auto session = std::make_shared<Session>(hs.TakeSession());
        c->parser.SetMaxPayload(kMaxPayloadBytes);
        backoff = cfg.backoff_min;
        std::uint64_t number = 0;
        std::size_t pending = 0;
        {
          std::lock_guard lock(m);
          number = ++connection;
          pending = store.size();
        }
        log("link: session " + std::to_string(number) + " authenticated, " +
            std::to_string(pending) + " clouds to send");
        current_session = session;
        status_due = true;
        asio::co_spawn(io, ReadLoop(c, session), asio::detached);
        std::function<void()> refill = [this, c, session, number] {
          if (c->alive) MaybeSendStatus(*c, *session);
          Refill(c, session.get(), number);
        };
        co_await Writer(c, session, cfg.heartbeat, refill);
      } catch (const std::exception& e) {
        log("link: " + cfg.host + ":" + std::to_string(cfg.port) + ": " + e.what() +
            "; retrying in " + std::to_string(backoff.count()) + " ms");
      }
      c->Close();
      current_session.reset();
      ++reconnects;
      asio::steady_timer pause(io, backoff);
      co_await pause.async_wait(use_awaitable);
      backoff = std::min(cfg.backoff_max, 2 * backoff);
    }
  }
};

ProbeLink::ProbeLink(ProbeLinkConfig config, Log log) : impl_(std::make_unique<Impl>()) {
  impl_->cfg = std::move(config);
  impl_->log = std::move(log);
}

ProbeLink::~ProbeLink() { Stop(); }

void ProbeLink::Start() {
  auto& d = *impl_;
  asio::co_spawn(d.io, d.Run(), asio::detached);
  d.thread = std::thread([&d] { d.io.run(); });
}

void ProbeLink::Stop() {
  if (!impl_ || !impl_->thread.joinable()) return;
  impl_->io.stop();
  impl_->thread.join();
}

SubmitResult ProbeLink::Submit(const LinkCloud& cloud) {
  return SubmitEncoded(cloud.capture_id, EncodeCloud(cloud, impl_->cfg.compress));
}

SubmitResult ProbeLink::SubmitEncoded(const std::string& capture_id, Bytes payload) {
  auto& d = *impl_;
  {
    std::lock_guard lock(d.m);
    for (const auto& p : d.store) {
      if (p.capture_id == capture_id) return SubmitResult::kDuplicate;
    }
    if (d.store.size() >= d.cfg.buffer_clouds) return SubmitResult::kBufferFull;
    d.store.push_back({capture_id, std::move(payload), 0});
    if (d.store.size() >= d.cfg.buffer_clouds) d.status_due = true;
  }
  asio::post(d.io, [&d] {
    if (d.current) d.current->wake.cancel();
  });
  return SubmitResult::kQueued;
}

std::size_t ProbeLink::Unacknowledged() const {
  std::lock_guard lock(impl_->m);
  return impl_->store.size();
}

bool ProbeLink::WaitAllAcknowledged(Millis timeout) const {
  std::unique_lock lock(impl_->m);
  return impl_->acked.wait_for(lock, timeout, [this] { return impl_->store.empty(); });
}

std::optional<CaptureRequest> ProbeLink::NextRequest(Millis timeout) {
  auto& d = *impl_;
  std::unique_lock lock(d.m);
  if (!d.request_cv.wait_for(lock, timeout, [&d] { return !d.requests.empty(); }))
    return std::nullopt;
  CaptureRequest r = std::move(d.requests.front());
  d.requests.pop_front();
  return r;
}

void ProbeLink::ReportError(ProbeError error) {
  auto& d = *impl_;
  // A message from an exception may be long or hold newlines: clipped and flattened, so that
  // reporting an error never fails.
  if (error.message.size() > kMaxMessageBytes) error.message.resize(kMaxMessageBytes);
  for (char& ch : error.message) {
    if (static_cast<unsigned char>(ch) < 0x20) ch = ' ';
  }
  Encode(error);  // throws here, in the caller's thread, for an unknown code or a bad id
  asio::post(d.io, [&d, error] {
    if (!d.current || !d.current->alive || !d.current_session) {
      d.log("link: not connected, error not sent: " + std::string(ToString(error.code)) + " " +
            error.capture_id + ": " + error.message);
      return;
    }
    d.SendError(*d.current, *d.current_session, error);
  });
}

void ProbeLink::SetStatusSource(std::function<ProbeStatus()> source) {
  impl_->status_source = std::move(source);
}

std::uint64_t ProbeLink::Reconnects() const { return impl_->reconnects; }

}  // namespace mlp::link
