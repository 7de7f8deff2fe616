#include "mlp/link/wire.h"

#include <cmath>
#include <cstring>

#include <boost/crc.hpp>

namespace mlp::link {
namespace {

constexpr std::uint8_t kMagic[4] = {'M', 'L', 'P', 'L'};

std::uint64_t Load(const std::uint8_t* p, int bytes) {
  std::uint64_t v = 0;
  for (int k = bytes - 1; k >= 0; --k) v = (v << 8) | p[k];
  return v;
}

void Store(Bytes* out, std::uint64_t v, int bytes) {
  for (int k = 0; k < bytes; ++k) out->push_back(static_cast<std::uint8_t>(v >> (8 * k)));
}

bool KnownType(std::uint8_t t) { return t >= 1 && t <= 9; }

}  // namespace

const char* ToString(LinkFault fault) {
  switch (fault) {
    case LinkFault::kBadMagic:
      return "bad_magic";
    case LinkFault::kUnsupportedVersion:
      return "unsupported_version";
    case LinkFault::kOversize:
      return "oversize";
    case LinkFault::kBadCrc:
      return "bad_crc";
    case LinkFault::kBadTag:
      return "bad_tag";
    case LinkFault::kReplay:
      return "replay";
    case LinkFault::kUnknownType:
      return "unknown_type";
    case LinkFault::kMalformedPayload:
      return "malformed_payload";
    case LinkFault::kUnknownProbe:
      return "unknown_probe";
    case LinkFault::kAuthFailed:
      return "auth_failed";
    case LinkFault::kProtocol:
      return "protocol";
    case LinkFault::kLocal:
      return "local";
  }
  return "unknown";
}

std::uint32_t Crc32c(const std::uint8_t* data, std::size_t size) {
  boost::crc_optimal<32, 0x1EDC6F41, 0xFFFFFFFF, 0xFFFFFFFF, true, true> crc;
  crc.process_bytes(data, size);
  return crc.checksum();
}

Bytes CoveredBytes(const Frame& f) {
  Bytes out(kMagic, kMagic + 4);
  out.reserve(kHeaderBytes + f.payload.size() + kCrcBytes + kTagBytes);
  Store(&out, f.version, 2);
  out.push_back(static_cast<std::uint8_t>(f.type));
  out.push_back(f.flags);
  Store(&out, f.sequence, 8);
  Store(&out, f.payload.size(), 4);
  out.insert(out.end(), f.payload.begin(), f.payload.end());
  return out;
}

Bytes Serialize(const Frame& f) {
  if (f.payload.size() > kMaxPayloadBytes) {
    throw LinkError(LinkFault::kOversize,
                    "payload of " + std::to_string(f.payload.size()) + " bytes");
  }
  Bytes out = CoveredBytes(f);
  Store(&out, Crc32c(out.data(), out.size()), 4);
  if (f.flags & kTagged) {
    if (f.tag.size() != kTagBytes)
      throw LinkError(LinkFault::kBadTag, "tagged frame without a tag");
    out.insert(out.end(), f.tag.begin(), f.tag.end());
  }
  return out;
}

void Parser::Feed(const std::uint8_t* data, std::size_t size) {
  if (start_ > 0 && start_ == buffer_.size()) buffer_.clear(), start_ = 0;
  if (start_ > (1u << 20) && start_ > buffer_.size() / 2) {  // compact now and then
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(start_));
    start_ = 0;
  }
  buffer_.insert(buffer_.end(), data, data + size);
}

bool Parser::Next(Frame* frame) {
  const std::uint8_t* p = buffer_.data() + start_;
  const std::size_t have = buffer_.size() - start_;
  // Check what has arrived as soon as it arrives: a wrong magic or version is refused at once.
  if (have >= 4 && std::memcmp(p, kMagic, 4) != 0)
    throw LinkError(LinkFault::kBadMagic, "not an mlprobe link frame");
  if (have >= 6 && Load(p + 4, 2) != kLinkVersion) {
    throw LinkError(LinkFault::kUnsupportedVersion,
                    "the peer speaks link version " + std::to_string(Load(p + 4, 2)) +
                        ", this program speaks " + std::to_string(kLinkVersion));
  }
  if (have < kHeaderBytes) return false;
  if (!KnownType(p[6]))
    throw LinkError(LinkFault::kUnknownType, "message type " + std::to_string(p[6]));
  const std::uint64_t length = Load(p + 16, 4);
  if (length > max_payload_) {
    throw LinkError(LinkFault::kOversize, "payload length " + std::to_string(length) + " exceeds " +
                                              std::to_string(max_payload_));
  }
  const bool tagged = p[7] & kTagged;
  if (p[7] & ~kTagged) throw LinkError(LinkFault::kProtocol, "unknown flags");
  const std::size_t total = kHeaderBytes + length + kCrcBytes + (tagged ? kTagBytes : 0);
  if (have < total) return false;
  const std::size_t covered = kHeaderBytes + length;
  if (Load(p + covered, 4) != Crc32c(p, covered))
    throw LinkError(LinkFault::kBadCrc, "frame checksum mismatch");
  frame->version = static_cast<std::uint16_t>(Load(p + 4, 2));
  frame->type = static_cast<MessageType>(p[6]);
  frame->flags = p[7];
  frame->sequence = Load(p + 8, 8);
  frame->payload.assign(p + kHeaderBytes, p + covered);
  frame->tag.assign(p + covered + kCrcBytes, p + total);
  start_ += total;
  return true;
}

void PutU8(Bytes* out, std::uint8_t v) { out->push_back(v); }
void PutU16(Bytes* out, std::uint16_t v) { Store(out, v, 2); }
void PutU32(Bytes* out, std::uint32_t v) { Store(out, v, 4); }
void PutU64(Bytes* out, std::uint64_t v) { Store(out, v, 8); }
void PutF64(Bytes* out, double v) {
  std::uint64_t bits = 0;
  std::memcpy(&bits, &v, 8);
  Store(out, bits, 8);
}
void PutString(Bytes* out, const std::string& s) {
  if (s.size() > 0xffff)
    throw LinkError(LinkFault::kMalformedPayload, "string longer than 65535 bytes");
  PutU16(out, static_cast<std::uint16_t>(s.size()));
  out->insert(out->end(), s.begin(), s.end());
}
void PutBlob(Bytes* out, const Bytes& b) {
  PutU32(out, static_cast<std::uint32_t>(b.size()));
  out->insert(out->end(), b.begin(), b.end());
}

const std::uint8_t* Reader::Take(std::size_t n) {
  if (n > size_ - at_) throw LinkError(LinkFault::kMalformedPayload, "payload ends early");
  const std::uint8_t* p = data_ + at_;
  at_ += n;
  return p;
}
std::uint8_t Reader::U8() { return *Take(1); }
std::uint16_t Reader::U16() { return static_cast<std::uint16_t>(Load(Take(2), 2)); }
std::uint32_t Reader::U32() { return static_cast<std::uint32_t>(Load(Take(4), 4)); }
std::uint64_t Reader::U64() { return Load(Take(8), 8); }
double Reader::F64() {
  const std::uint64_t bits = U64();
  double v = 0.0;
  std::memcpy(&v, &bits, 8);
  if (!std::isfinite(v)) throw LinkError(LinkFault::kMalformedPayload, "non-finite number");
  return v;
}
std::string Reader::String(std::size_t max_size) {
  const std::size_t n = U16();
  if (n > max_size) throw LinkError(LinkFault::kMalformedPayload, "string too long");
  const auto* p = Take(n);
  return std::string(p, p + n);
}
Bytes Reader::Blob(std::size_t max_size) {
  const std::size_t n = U32();
  if (n > max_size) throw LinkError(LinkFault::kMalformedPayload, "blob too long");
  const auto* p = Take(n);
  return Bytes(p, p + n);
}
void Reader::ExpectEnd() const {
  if (at_ != size_) throw LinkError(LinkFault::kMalformedPayload, "trailing bytes in payload");
}

}  // namespace mlp::link
