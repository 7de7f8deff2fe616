#pragma once
/// @file Mutual authentication with a per-probe pre-shared key and per-frame HMAC-SHA256
/// (OpenSSL libcrypto), docs/LINK.md:
///
///   probe -> host  HELLO      versions, serial, nonce_p (32 random bytes)
///   host -> probe  CHALLENGE  version, nonce_h, HMAC(K, "mlprobe host"  | serial | nonce_p |
///   nonce_h) probe -> host  AUTH       HMAC(K, "mlprobe probe" | serial | nonce_p | nonce_h)
///
/// then one key per direction, HMAC(K, "mlprobe p2h" | nonce_p | nonce_h) and "h2p", tags every
/// frame (header + payload), and each direction's sequence numbers must rise by exactly one:
/// a replayed, reordered, altered or reflected frame fails. Fresh nonces on both sides make a
/// recorded session useless. Proofs are compared in constant time.

#include "mlp/link/wire.h"

#include <functional>
#include <optional>
#include <string>

namespace mlp::link {

/// A pre-shared key, 32 bytes or more.
struct Key {
  Bytes bytes;
};

/// Reads a key file: hex digits (64 or more, whitespace ignored). Refuses a file that group or
/// others may read (the key must be owner-only, mode 0600 or 0400). Never prints the key.
Key LoadKeyFile(const std::string& path);

/// HMAC-SHA256.
Bytes Hmac(const Bytes& key, const Bytes& message);

/// An authenticated session: seals outgoing frames and opens incoming ones.
class Session {
 public:
  Session() = default;
  Session(Bytes send_key, Bytes receive_key)
      : send_key_(std::move(send_key)), receive_key_(std::move(receive_key)) {}
  /// A tagged frame with the next sequence number.
  Frame Seal(MessageType type, Bytes payload);
  /// Throws LinkError: kBadTag (missing, wrong or altered), kReplay (sequence not last + 1).
  void Open(const Frame& frame);
  bool Ready() const { return !send_key_.empty(); }

 private:
  Bytes send_key_, receive_key_;
  std::uint64_t sent_ = 0, received_ = 0;
};

class ProbeHandshake {
 public:
  ProbeHandshake(std::string serial, Key key);
  Frame Hello();
  /// Checks the host's proof (kAuthFailed: the host does not hold this probe's key) and answers
  /// with AUTH; the session is then ready.
  Frame OnChallenge(const Frame& challenge);
  Session TakeSession() { return std::move(session_); }

 private:
  std::string serial_;
  Key key_;
  Bytes nonce_p_;
  Session session_;
};

class HostHandshake {
 public:
  /// The key of a known probe serial, or nothing: only known probes are admitted.
  using KeyLookup = std::function<std::optional<Key>(const std::string& serial)>;
  explicit HostHandshake(KeyLookup lookup) : lookup_(std::move(lookup)) {}
  /// kUnknownProbe, kUnsupportedVersion (no common version) or kMalformedPayload.
  Frame OnHello(const Frame& hello);
  /// kAuthFailed when the probe's proof is wrong.
  void OnAuth(const Frame& auth);
  const std::string& serial() const { return serial_; }
  Session TakeSession() { return std::move(session_); }

 private:
  KeyLookup lookup_;
  std::string serial_;
  Key key_;
  Bytes nonce_p_, nonce_h_;
  Session session_;
  bool challenged_ = false;
};

}  // namespace mlp::link
