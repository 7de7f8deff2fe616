#include "mlp/link/auth.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>
#include <sys/stat.h>

namespace mlp::link {
namespace {

constexpr std::size_t kNonceBytes = 32;
constexpr std::size_t kMaxSerial = 64;

Bytes Random(std::size_t n) {
  Bytes b(n);
  if (RAND_bytes(b.data(), static_cast<int>(n)) != 1)
    throw LinkError(LinkFault::kLocal, "no randomness");
  return b;
}

Bytes Transcript(const char* label, const std::string& serial, const Bytes& a, const Bytes& b) {
  Bytes m(label, label + std::strlen(label));
  PutString(&m, serial);
  m.insert(m.end(), a.begin(), a.end());
  m.insert(m.end(), b.begin(), b.end());
  return m;
}

bool Equal(const Bytes& a, const std::uint8_t* b, std::size_t n) {
  return a.size() == n && CRYPTO_memcmp(a.data(), b, n) == 0;
}

void Expect(const Frame& f, MessageType type) {
  if (f.type != type || (f.flags & kTagged)) {
    throw LinkError(LinkFault::kProtocol, "unexpected message during the handshake");
  }
}

}  // namespace

Bytes Hmac(const Bytes& key, const Bytes& message) {
  Bytes out(EVP_MAX_MD_SIZE);
  unsigned len = 0;
  if (!HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), message.data(), message.size(),
            out.data(), &len)) {
    throw LinkError(LinkFault::kLocal, "HMAC failed");
  }
  out.resize(len);
  return out;
}

Key LoadKeyFile(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) throw LinkError(LinkFault::kAuthFailed, "no key file " + path);
  if (!S_ISREG(st.st_mode)) {
    throw LinkError(LinkFault::kAuthFailed, "key file " + path + " is not a regular file");
  }
  if (st.st_mode & 077) {
    throw LinkError(LinkFault::kAuthFailed,
                    "key file " + path + " is readable by group or others (chmod 600 it)");
  }
  constexpr off_t kMaxKeyFileBytes = 4096;  // a key is 64..a few hundred hex digits
  if (st.st_size > kMaxKeyFileBytes) {
    throw LinkError(LinkFault::kAuthFailed, "key file " + path + " is too large for a key (" +
                                                std::to_string(st.st_size) + " bytes)");
  }
  std::ifstream in(path);
  const int open_errno = errno;
  std::stringstream text;
  if (in) text << in.rdbuf();
  if (!in || in.bad()) {  // not "must hold 32 bytes": the file was never read
    throw LinkError(LinkFault::kAuthFailed,
                    "cannot read key file " + path + " (" + std::strerror(open_errno) + ")");
  }
  std::string hex;
  for (char c : text.str()) {
    if (std::isspace(static_cast<unsigned char>(c))) continue;
    if (!std::isxdigit(static_cast<unsigned char>(c))) {
      throw LinkError(LinkFault::kAuthFailed, "key file " + path + " must hold hex digits only");
    }
    hex += c;
  }
  if (hex.size() < 64 || hex.size() % 2) {
    throw LinkError(LinkFault::kAuthFailed,
                    "key file " + path + " must hold 32 bytes or more (64 hex digits)");
  }
  Key key;
  for (std::size_t i = 0; i < hex.size(); i += 2) {
    key.bytes.push_back(static_cast<std::uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return key;
}

Frame Session::Seal(MessageType type, Bytes payload) {
  Frame f;
  f.type = type;
  f.flags = kTagged;
  f.sequence = ++sent_;
  f.payload = std::move(payload);
  f.tag = Hmac(send_key_, CoveredBytes(f));
  return f;
}

void Session::Open(const Frame& f) {
  if (!(f.flags & kTagged) || f.tag.size() != kTagBytes) {
    throw LinkError(LinkFault::kBadTag, "untagged frame in an authenticated session");
  }
  const Bytes expected = Hmac(receive_key_, CoveredBytes(f));
  if (!Equal(expected, f.tag.data(), f.tag.size()))
    throw LinkError(LinkFault::kBadTag, "frame tag mismatch");
  if (f.sequence != received_ + 1) {
    throw LinkError(LinkFault::kReplay, "sequence " + std::to_string(f.sequence) + " after " +
                                            std::to_string(received_));
  }
  received_ = f.sequence;
}

ProbeHandshake::ProbeHandshake(std::string serial, Key key)
    : serial_(std::move(serial)), key_(std::move(key)) {}

Frame ProbeHandshake::Hello() {
  nonce_p_ = Random(kNonceBytes);
  Frame f;
  f.type = MessageType::kHello;
  PutU16(&f.payload, kLinkVersion);  // lowest version spoken
  PutU16(&f.payload, kLinkVersion);  // highest
  PutString(&f.payload, serial_);
  f.payload.insert(f.payload.end(), nonce_p_.begin(), nonce_p_.end());
  return f;
}

Frame ProbeHandshake::OnChallenge(const Frame& challenge) {
  Expect(challenge, MessageType::kChallenge);
  if (nonce_p_.empty()) throw LinkError(LinkFault::kProtocol, "challenge before hello");
  Reader r(challenge.payload);
  const std::uint16_t version = r.U16();
  if (version != kLinkVersion)
    throw LinkError(LinkFault::kUnsupportedVersion,
                    "host chose version " + std::to_string(version));
  const std::uint8_t* nh = r.Take(kNonceBytes);
  const Bytes nonce_h(nh, nh + kNonceBytes);
  const std::uint8_t* host_proof = r.Take(kTagBytes);
  r.ExpectEnd();
  if (!Equal(Hmac(key_.bytes, Transcript("mlprobe host", serial_, nonce_p_, nonce_h)), host_proof,
             kTagBytes)) {
    throw LinkError(LinkFault::kAuthFailed, "the host does not hold this probe's key");
  }
  Frame auth;
  auth.type = MessageType::kAuth;
  auth.payload = Hmac(key_.bytes, Transcript("mlprobe probe", serial_, nonce_p_, nonce_h));
  session_ = Session(Hmac(key_.bytes, Transcript("mlprobe p2h", "", nonce_p_, nonce_h)),
                     Hmac(key_.bytes, Transcript("mlprobe h2p", "", nonce_p_, nonce_h)));
  return auth;
}

Frame HostHandshake::OnHello(const Frame& hello) {
  Expect(hello, MessageType::kHello);
  Reader r(hello.payload);
  const std::uint16_t lowest = r.U16(), highest = r.U16();
  serial_ = r.String(kMaxSerial);
  const std::uint8_t* nonce = r.Take(kNonceBytes);
  r.ExpectEnd();
  // A serial is printable ASCII: anything else is refused before it reaches a log line, a
  // file name or a JSON reply (bytes that are not UTF-8 made the host's logger throw).
  const bool printable =
      !serial_.empty() &&
      std::all_of(serial_.begin(), serial_.end(), [](char c) { return c > ' ' && c < 0x7f; });
  if (!printable) {
    std::string shown;
    for (unsigned char c : serial_.substr(0, 16)) {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%02x", c);
      shown += hex;
    }
    serial_.clear();
    throw LinkError(LinkFault::kMalformedPayload,
                    "serial is not printable ASCII (hex " + shown + ")");
  }
  if (lowest > kLinkVersion || highest < kLinkVersion) {
    throw LinkError(LinkFault::kUnsupportedVersion,
                    "probe " + serial_ + " speaks versions " + std::to_string(lowest) + ".." +
                        std::to_string(highest) + ", this host " + std::to_string(kLinkVersion));
  }
  const auto key = lookup_(serial_);
  if (!key)
    throw LinkError(LinkFault::kUnknownProbe, "probe serial '" + serial_ + "' is not configured");
  key_ = *key;
  nonce_p_.assign(nonce, nonce + kNonceBytes);
  nonce_h_ = Random(kNonceBytes);
  Frame f;
  f.type = MessageType::kChallenge;
  PutU16(&f.payload, kLinkVersion);
  f.payload.insert(f.payload.end(), nonce_h_.begin(), nonce_h_.end());
  const Bytes proof = Hmac(key_.bytes, Transcript("mlprobe host", serial_, nonce_p_, nonce_h_));
  f.payload.insert(f.payload.end(), proof.begin(), proof.end());
  challenged_ = true;
  return f;
}

void HostHandshake::OnAuth(const Frame& auth) {
  Expect(auth, MessageType::kAuth);
  if (!challenged_) throw LinkError(LinkFault::kProtocol, "auth before hello");
  if (!Equal(Hmac(key_.bytes, Transcript("mlprobe probe", serial_, nonce_p_, nonce_h_)),
             auth.payload.data(), auth.payload.size())) {
    throw LinkError(LinkFault::kAuthFailed, "probe " + serial_ + " failed to prove its key");
  }
  session_ = Session(Hmac(key_.bytes, Transcript("mlprobe h2p", "", nonce_p_, nonce_h_)),
                     Hmac(key_.bytes, Transcript("mlprobe p2h", "", nonce_p_, nonce_h_)));
}

}  // namespace mlp::link
