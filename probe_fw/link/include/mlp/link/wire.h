#pragma once
/// @file The probe link's framing (docs/LINK.md): every message is one frame
///
///   magic "MLPL" | version u16 | type u8 | flags u8 | sequence u64 | payload length u32 |
///   payload | CRC-32C u32 (of all before it) | HMAC-SHA256 tag, 32 bytes (if flags & kTagged)
///
/// little-endian. The parser is incremental (bytes arrive in any pieces), checks the length
/// before allocating, and reports every defect as a typed LinkError; it never trusts a field it
/// has not checked. Authentication of tagged frames is auth.h's job.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::link {

using Bytes = std::vector<std::uint8_t>;

// 2: STATUS carries frames dropped and the last error; 3: CLOUD carries the LED frame's edge.
constexpr std::uint16_t kLinkVersion = 4;
constexpr std::size_t kHeaderBytes = 20;
constexpr std::size_t kCrcBytes = 4;
constexpr std::size_t kTagBytes = 32;
/// Largest payload accepted: a 2048 x 1536 sensor's worth of points at 16 bytes each is 50 MB.
constexpr std::uint32_t kMaxPayloadBytes = 64u << 20;
/// Largest payload accepted before the peer has authenticated: a HELLO, CHALLENGE or AUTH is
/// under 200 bytes. An unauthenticated peer must not make the host allocate a cloud's worth.
constexpr std::uint32_t kMaxHandshakePayloadBytes = 1024;
/// Capture ids, serials and calibration ids, at most.
constexpr std::size_t kMaxIdBytes = 256;

enum class MessageType : std::uint8_t {
  kHello = 1,      ///< probe -> host: versions, serial, nonce
  kChallenge = 2,  ///< host -> probe: chosen version, nonce, host's proof
  kAuth = 3,       ///< probe -> host: probe's proof
  kCaptureRequest = 4,
  kCloud = 5,
  kStatus = 6,
  kAck = 7,
  kError = 8,
  kHeartbeat = 9,
};

enum FrameFlags : std::uint8_t {
  kTagged = 1,  ///< an HMAC tag follows the CRC (every frame after the handshake)
};

enum class LinkFault {
  kBadMagic,
  kUnsupportedVersion,
  kOversize,
  kBadCrc,
  kBadTag,
  kReplay,
  kUnknownType,
  kMalformedPayload,
  kUnknownProbe,
  kAuthFailed,
  kProtocol,  ///< a message that is valid but not expected in this state
  kLocal,     ///< this end failed: randomness, a hash, the compressor, a socket to listen on
};

const char* ToString(LinkFault fault);

class LinkError : public std::runtime_error {
 public:
  LinkError(LinkFault fault, const std::string& message)
      : std::runtime_error(std::string(ToString(fault)) + ": " + message), fault_(fault) {}
  LinkFault fault() const { return fault_; }

 private:
  LinkFault fault_;
};

struct Frame {
  std::uint16_t version = kLinkVersion;
  MessageType type = MessageType::kHeartbeat;
  std::uint8_t flags = 0;
  std::uint64_t sequence = 0;
  Bytes payload;
  Bytes tag;  ///< kTagBytes when flags & kTagged
};

/// Header + payload: the bytes the CRC and the tag cover.
Bytes CoveredBytes(const Frame& frame);
/// The whole frame on the wire; `tag` must be set when the frame is tagged.
Bytes Serialize(const Frame& frame);

/// CRC-32C (Castagnoli, as iSCSI and ext4; Boost.CRC).
std::uint32_t Crc32c(const std::uint8_t* data, std::size_t size);

/// Incremental parser: Feed bytes as they arrive, take frames with Next.
class Parser {
 public:
  void Feed(const std::uint8_t* data, std::size_t size);
  /// True and a frame when one is complete; false when more bytes are needed. Throws LinkError
  /// on a defect; the stream cannot be resynchronised after that (the caller drops the
  /// connection).
  bool Next(Frame* frame);
  std::size_t Buffered() const { return buffer_.size() - start_; }
  /// The largest payload taken (kMaxPayloadBytes unless lowered, e.g. to
  /// kMaxHandshakePayloadBytes before authentication); a larger one is kOversize.
  void SetMaxPayload(std::uint32_t bytes) { max_payload_ = bytes; }

 private:
  Bytes buffer_;
  std::size_t start_ = 0;
  std::uint32_t max_payload_ = kMaxPayloadBytes;
};

/// Little-endian writers and a bounds-checked reader for payloads.
void PutU8(Bytes* out, std::uint8_t v);
void PutU16(Bytes* out, std::uint16_t v);
void PutU32(Bytes* out, std::uint32_t v);
void PutU64(Bytes* out, std::uint64_t v);
void PutF64(Bytes* out, double v);
void PutString(Bytes* out, const std::string& s);  ///< u16 length + bytes
void PutBlob(Bytes* out, const Bytes& b);          ///< u32 length + bytes

class Reader {
 public:
  Reader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  explicit Reader(const Bytes& b) : Reader(b.data(), b.size()) {}
  std::uint8_t U8();
  std::uint16_t U16();
  std::uint32_t U32();
  std::uint64_t U64();
  double F64();  ///< throws kMalformedPayload on NaN or infinity
  std::string String(std::size_t max_size);
  Bytes Blob(std::size_t max_size);
  const std::uint8_t* Take(std::size_t n);
  std::size_t Left() const { return size_ - at_; }
  void ExpectEnd() const;

 private:
  const std::uint8_t* data_;
  std::size_t size_, at_ = 0;
};

}  // namespace mlp::link
