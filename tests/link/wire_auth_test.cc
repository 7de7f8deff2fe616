// The link's framing and authentication without sockets: every defect of issue 4's list is a
// typed rejection, and an honest exchange passes.

#include "mlp/link/auth.h"
#include "mlp/link/wire.h"

#include <filesystem>
#include <fstream>
#include <random>

#include "link_test_util.h"
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace mlp::link {
namespace {

using testing::FaultOf;

Key TestKey(std::uint8_t seed) { return Key{Bytes(32, seed)}; }

Frame Parse(const Bytes& wire) {
  Parser p;
  p.Feed(wire.data(), wire.size());
  Frame f;
  if (!p.Next(&f)) throw std::logic_error("incomplete frame");
  return f;
}

struct Pair {
  Session probe, host;
};

Pair Handshake(const Key& probe_key, const Key& host_key) {
  ProbeHandshake probe("MLP-1", probe_key);
  HostHandshake host([&](const std::string& s) -> std::optional<Key> {
    if (s == "MLP-1") return host_key;
    return std::nullopt;
  });
  const Frame challenge = Parse(Serialize(host.OnHello(Parse(Serialize(probe.Hello())))));
  host.OnAuth(Parse(Serialize(probe.OnChallenge(challenge))));
  return {probe.TakeSession(), host.TakeSession()};
}

TEST(Wire, FramesSurviveAnySplitOfTheByteStream) {
  std::mt19937 gen(3);
  Bytes stream;
  for (int i = 0; i < 50; ++i) {
    Frame f;
    f.type = MessageType::kStatus;
    f.sequence = static_cast<std::uint64_t>(i);
    f.payload.resize(static_cast<size_t>(gen() % 3000));
    for (auto& b : f.payload) b = static_cast<std::uint8_t>(gen());
    const Bytes w = Serialize(f);
    stream.insert(stream.end(), w.begin(), w.end());
  }
  Parser p;
  size_t at = 0, got = 0;
  Frame f;
  while (at < stream.size()) {
    const size_t n = std::min<size_t>(1 + gen() % 700, stream.size() - at);
    p.Feed(stream.data() + at, n);
    at += n;
    while (p.Next(&f)) EXPECT_EQ(f.sequence, got++);
  }
  EXPECT_EQ(got, 50u);
  EXPECT_EQ(p.Buffered(), 0u);
}

TEST(Wire, EveryDefectIsTyped) {
  Frame f;
  f.type = MessageType::kStatus;
  f.payload = {1, 2, 3};
  const Bytes good = Serialize(f);
  Bytes w = good;
  w[0] = 'X';
  EXPECT_EQ(FaultOf([&] { Parse(w); }), LinkFault::kBadMagic);
  w = good;
  w[4] = kLinkVersion + 1;  // a newer probe
  EXPECT_EQ(FaultOf([&] { Parse(w); }), LinkFault::kUnsupportedVersion);
  w = good;
  w[6] = 77;
  EXPECT_EQ(FaultOf([&] { Parse(w); }), LinkFault::kUnknownType);
  w = good;
  w[19] = 0x7f;  // length ~2 GB: refused before any allocation
  EXPECT_EQ(FaultOf([&] { Parse(w); }), LinkFault::kOversize);
  w = good;
  w[21] ^= 0x01;  // one payload bit
  EXPECT_EQ(FaultOf([&] { Parse(w); }), LinkFault::kBadCrc);
  EXPECT_EQ(Parse(good).payload, f.payload);
}

TEST(Auth, HonestSessionCarriesFramesBothWays) {
  Pair s = Handshake(TestKey(7), TestKey(7));
  for (int i = 0; i < 5; ++i) {
    s.host.Open(Parse(Serialize(s.probe.Seal(MessageType::kCloud, {1, 2, 3}))));
    s.probe.Open(Parse(Serialize(s.host.Seal(MessageType::kAck, {4}))));
  }
}

TEST(Auth, WrongKeyFailsOnBothSides) {
  ProbeHandshake probe("MLP-1", TestKey(1));
  HostHandshake host([](const std::string&) -> std::optional<Key> { return TestKey(2); });
  const Frame challenge = host.OnHello(probe.Hello());
  EXPECT_EQ(FaultOf([&] { probe.OnChallenge(challenge); }), LinkFault::kAuthFailed);
  // A probe that skips checking the host still cannot prove a key it does not have.
  Frame forged;
  forged.type = MessageType::kAuth;
  forged.payload = Bytes(32, 0);
  EXPECT_EQ(FaultOf([&] { host.OnAuth(forged); }), LinkFault::kAuthFailed);
}

TEST(Auth, UnknownSerialAndVersionRangeAreRefused) {
  ProbeHandshake probe("MLP-9", TestKey(1));
  HostHandshake host([](const std::string&) -> std::optional<Key> { return std::nullopt; });
  EXPECT_EQ(FaultOf([&] { host.OnHello(probe.Hello()); }), LinkFault::kUnknownProbe);
  Frame hello = ProbeHandshake("MLP-1", TestKey(1)).Hello();
  hello.payload[0] = 5, hello.payload[2] = 6;  // a probe that speaks only versions 5..6
  HostHandshake host2([](const std::string&) -> std::optional<Key> { return TestKey(1); });
  EXPECT_EQ(FaultOf([&] { host2.OnHello(hello); }), LinkFault::kUnsupportedVersion);
}

TEST(Auth, ReplayedSessionFails) {
  // Record an honest handshake's AUTH, then replay it against a fresh challenge.
  ProbeHandshake probe("MLP-1", TestKey(7));
  auto lookup = [](const std::string&) -> std::optional<Key> { return TestKey(7); };
  HostHandshake host1(lookup);
  const Frame hello = probe.Hello();
  const Frame recorded_auth = probe.OnChallenge(host1.OnHello(hello));
  HostHandshake host2(lookup);
  host2.OnHello(hello);  // the attacker replays the hello: a new nonce_h comes back
  EXPECT_EQ(FaultOf([&] { host2.OnAuth(recorded_auth); }), LinkFault::kAuthFailed);
}

TEST(Auth, AlteredReplayedReflectedOrUntaggedFramesFail) {
  Pair s = Handshake(TestKey(7), TestKey(7));
  const Frame first = s.probe.Seal(MessageType::kCloud, {1, 2, 3});
  Frame altered = first;
  altered.payload[1] ^= 0x10;  // an attacker who also fixes the CRC: Serialize recomputes it
  EXPECT_EQ(FaultOf([&] { s.host.Open(Parse(Serialize(altered))); }), LinkFault::kBadTag);
  s.host.Open(first);
  EXPECT_EQ(FaultOf([&] { s.host.Open(first); }), LinkFault::kReplay);
  const Frame second = s.probe.Seal(MessageType::kCloud, {9});          // sequence 2
  const Frame third = s.probe.Seal(MessageType::kCloud, {9});           // sequence 3
  EXPECT_EQ(FaultOf([&] { s.host.Open(third); }), LinkFault::kReplay);  // out of order
  s.host.Open(second);
  // The host's own frame sent back to it (reflection) carries the other direction's key.
  const Frame from_host = s.host.Seal(MessageType::kAck, {1});
  EXPECT_EQ(FaultOf([&] { s.host.Open(from_host); }), LinkFault::kBadTag);
  Frame untagged;
  untagged.type = MessageType::kCloud;
  EXPECT_EQ(FaultOf([&] { s.host.Open(untagged); }), LinkFault::kBadTag);
}

TEST(Auth, KeyFilesMustBeOwnerOnly) {
  const auto path = std::filesystem::temp_directory_path() / "mlp_link_key_test";
  std::ofstream(path) << std::string(64, 'a') << "\n";
  chmod(path.c_str(), 0644);
  try {
    LoadKeyFile(path.string());
    ADD_FAILURE() << "world-readable key accepted";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("chmod 600"), std::string::npos);
    EXPECT_EQ(std::string(e.what()).find("aaaa"), std::string::npos);  // never the key itself
  }
  chmod(path.c_str(), 0600);
  EXPECT_EQ(LoadKeyFile(path.string()).bytes, Bytes(32, 0xaa));
  std::ofstream(path) << "abcd";
  EXPECT_THROW(LoadKeyFile(path.string()), LinkError);  // too short
  std::filesystem::remove(path);
}

std::string KeyFileError(const std::string& path) {
  try {
    LoadKeyFile(path);
  } catch (const LinkError& e) {
    return e.what();
  }
  return "accepted";
}

// An unreadable key file was reported as "must hold 32 bytes", sending the operator to the
// key's contents instead of its permissions.
TEST(Auth, AKeyFileThatCannotBeReadSaysSo) {
  const auto dir = std::filesystem::temp_directory_path() / "mlp_link_key_dir";
  std::filesystem::create_directories(dir);
  chmod(dir.c_str(), 0711);  // others may pass through to the file, not list
  EXPECT_NE(KeyFileError(dir.string()).find("is not a regular file"), std::string::npos);
  const auto key = dir / "k.key";
  std::ofstream(key) << std::string(64, 'a') << "\n";
  chmod(key.c_str(), 0600);
  // Read as another user (the service's user is not root): root reads any file, so the test
  // drops to "nobody" in a child when it runs as root.
  int pipe_fd[2];
  ASSERT_EQ(pipe(pipe_fd), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (geteuid() == 0 && setuid(65534) != 0) _exit(3);
    if (geteuid() != 0) chmod(key.c_str(), 0);  // the owner cannot read it either now
    const std::string message = KeyFileError(key.string());
    const ssize_t n = write(pipe_fd[1], message.data(), message.size());
    _exit(n == static_cast<ssize_t>(message.size()) ? 0 : 4);
  }
  close(pipe_fd[1]);
  std::string message(512, '\0');
  const ssize_t n = read(pipe_fd[0], message.data(), message.size());
  close(pipe_fd[0]);
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
  message.resize(n > 0 ? n : 0);
  EXPECT_NE(message.find("cannot read key file"), std::string::npos) << message;
  EXPECT_NE(message.find("Permission denied"), std::string::npos) << message;
  std::ofstream(key) << std::string(10000, 'a');
  EXPECT_NE(KeyFileError(key.string()).find("too large"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mlp::link
