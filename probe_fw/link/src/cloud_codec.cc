#include "mlp/link/cloud_codec.h"

#include "mlp/base/pose.h"

#include <cmath>
#include <limits>

#include <zstd.h>

namespace mlp::link {
namespace {

constexpr std::uint8_t kRaw = 0, kZstd = 1;
constexpr int kZstdLevel = 3;  // zstd's default: most of the gain at a fraction of the time
// A delta of two int32 values needs 33 bits, zig-zagged 34: five 7-bit varint bytes.
constexpr std::size_t kMaxVarint = 5;

[[noreturn]] void Bad(const std::string& what) {
  throw LinkError(LinkFault::kMalformedPayload, "cloud: " + what);
}

std::uint64_t ZigZag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t UnZigZag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

void PutVarint(Bytes* out, std::uint64_t v) {
  while (v >= 0x80) out->push_back(static_cast<std::uint8_t>(v | 0x80)), v >>= 7;
  out->push_back(static_cast<std::uint8_t>(v));
}

std::uint64_t GetVarint(Reader* r) {
  std::uint64_t v = 0;
  for (int shift = 0; shift < 64; shift += 7) {
    const std::uint8_t b = r->U8();
    v |= static_cast<std::uint64_t>(b & 0x7f) << shift;
    if (!(b & 0x80)) return v;
  }
  Bad("varint longer than 64 bits");
}

std::int32_t Quantise(double mm) {
  if (!std::isfinite(mm)) Bad("non-finite coordinate");
  const double q = std::round(mm / kResolutionMm);
  if (std::abs(q) > std::numeric_limits<std::int32_t>::max()) Bad("coordinate beyond +-214 m");
  return static_cast<std::int32_t>(q);
}

std::uint8_t QuantiseQuality(float q) {
  if (!(q >= 0.0f && q <= 1.0f)) Bad("quality outside 0..1");
  return static_cast<std::uint8_t>(std::lround(q * 255.0f));
}

// The body: per axis a stream of zig-zag varint deltas, then the quality bytes.
Bytes Body(const LinkCloud& c) {
  Bytes streams[3];
  std::int64_t previous[3] = {0, 0, 0};
  for (std::size_t i = 0; i < c.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      const std::int64_t q = Quantise(c.xyz[3 * i + a]);
      PutVarint(&streams[a], ZigZag(q - previous[a]));
      previous[a] = q;
    }
  }
  Bytes body;
  for (const Bytes& s : streams) PutBlob(&body, s);
  for (float q : c.quality) body.push_back(QuantiseQuality(q));
  return body;
}

void ReadBody(const Bytes& body, LinkCloud* c, std::size_t n) {
  Reader r(body);
  Bytes streams[3];
  for (Bytes& s : streams) {
    s = r.Blob(kMaxVarint * n);
    // Every point takes at least one byte per stream: check before allocating for n points.
    if (s.size() < n) Bad("coordinate stream shorter than its point count");
  }
  if (r.Left() != n) Bad("quality bytes do not match the point count");
  c->xyz.assign(3 * n, 0.0);
  for (int a = 0; a < 3; ++a) {
    Reader s(streams[a]);
    std::int64_t value = 0;
    for (std::size_t i = 0; i < n; ++i) {
      value += UnZigZag(GetVarint(&s));
      if (std::abs(value) > std::numeric_limits<std::int32_t>::max())
        Bad("coordinate out of range");
      c->xyz[3 * i + a] = static_cast<double>(value) * kResolutionMm;
    }
    s.ExpectEnd();
  }
  const std::uint8_t* q = r.Take(n);
  c->quality.resize(n);
  for (std::size_t i = 0; i < n; ++i) c->quality[i] = static_cast<float>(q[i]) / 255.0f;
  r.ExpectEnd();
}

// The edge: a presence byte, then its ten numbers and point count (base/edge_sight.h).
void PutEdge(Bytes* out, const std::optional<base::EdgeSight>& edge) {
  PutU8(out, edge ? 1 : 0);
  if (!edge) return;
  const std::array<double, 10> v = base::EdgeSightNumbers(*edge);
  base::EdgeSight checked;
  std::string why;
  if (!base::EdgeSightFromNumbers(v, edge->points, &checked, &why)) Bad("edge: " + why);
  for (double x : v) PutF64(out, x);
  PutU32(out, edge->points);
}

std::optional<base::EdgeSight> GetEdge(Reader* r) {
  const std::uint8_t present = r->U8();
  if (present == 0) return std::nullopt;
  if (present != 1) Bad("edge presence byte " + std::to_string(present));
  std::array<double, 10> v{};
  for (double& x : v) x = r->F64();
  const std::uint32_t points = r->U32();
  base::EdgeSight edge;
  std::string why;
  if (!base::EdgeSightFromNumbers(v, points, &edge, &why)) Bad("edge: " + why);
  return edge;
}

// The stripe account: a count of fields, then each as a u64 (link version 4).
constexpr std::uint8_t kAccountFields = 13;
std::array<std::uint64_t*, kAccountFields> AccountFields(StripeAccount& a) {
  return {&a.kept,
          &a.weak,
          &a.cut,
          &a.saturated,
          &a.double_peak,
          &a.too_wide,
          &a.too_narrow,
          &a.indirect,
          &a.second_on_line,
          &a.undecided_on_line,
          &a.beside_rejected,
          &a.reflectance,
          &a.isolated};
}
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 40;

void PutAccount(Bytes* out, StripeAccount a) {
  PutU8(out, kAccountFields);
  for (std::uint64_t* v : AccountFields(a)) {
    if (*v > kMaxCount) Bad("a stripe count over 2^40");
    PutU64(out, *v);
  }
}

StripeAccount GetAccount(Reader* r) {
  if (r->U8() != kAccountFields)
    Bad("stripe account: not " + std::to_string(kAccountFields) + " fields");
  StripeAccount a;
  for (std::uint64_t* v : AccountFields(a)) {
    *v = r->U64();
    if (*v > kMaxCount) Bad("stripe account: a count over 2^40");
  }
  return a;
}

}  // namespace

double StripeAccount::RejectedShare() const {
  const double rejected = static_cast<double>(saturated + double_peak + too_wide + too_narrow +
                                              indirect + second_on_line + undecided_on_line +
                                              beside_rejected + reflectance + isolated);
  const double light = static_cast<double>(kept) + rejected;
  return light > 0.0 ? rejected / light : 0.0;
}

Bytes EncodeCloud(const LinkCloud& c, bool compress) {
  if (c.xyz.size() != 3 * c.quality.size()) Bad("xyz and quality sizes differ");
  if (c.size() > kMaxCloudPoints) Bad("more than " + std::to_string(kMaxCloudPoints) + " points");
  for (const std::string* text : {&c.capture_id, &c.probe_serial, &c.calibration_id}) {
    // The decoder's limit, enforced here too: a cloud the host must refuse is never queued.
    if (text->size() > kMaxIdBytes)
      Bad("an id longer than " + std::to_string(kMaxIdBytes) + " bytes");
  }
  Bytes out;
  PutString(&out, c.capture_id);
  PutString(&out, c.probe_serial);
  PutString(&out, c.calibration_id);
  std::string why;
  Eigen::Isometry3d checked;
  const std::array<double, 16> h = base::RowMajor(c.mcs_from_flange);
  if (!base::PoseFromRowMajor(h, &checked, &why)) Bad("flange pose: " + why);
  for (double v : h) PutF64(&out, v);
  PutU64(&out, static_cast<std::uint64_t>(c.first_frame_ns));
  PutU64(&out, static_cast<std::uint64_t>(c.last_frame_ns));
  PutU64(&out, static_cast<std::uint64_t>(c.processed_ns));
  PutEdge(&out, c.edge);
  PutAccount(&out, c.stripes);
  PutU32(&out, static_cast<std::uint32_t>(c.size()));
  const Bytes body = Body(c);
  if (!compress) {
    PutU8(&out, kRaw);
    PutBlob(&out, body);
    return out;
  }
  Bytes packed(ZSTD_compressBound(body.size()));
  const std::size_t n =
      ZSTD_compress(packed.data(), packed.size(), body.data(), body.size(), kZstdLevel);
  if (ZSTD_isError(n))
    throw LinkError(LinkFault::kLocal, std::string("zstd: ") + ZSTD_getErrorName(n));
  packed.resize(n);
  PutU8(&out, kZstd);
  PutU32(&out, static_cast<std::uint32_t>(body.size()));
  PutBlob(&out, packed);
  return out;
}

namespace {

// The metadata up to and including the point count, which it checks against the limit.
std::size_t ReadHeader(Reader* r, LinkCloud* c) {
  c->capture_id = r->String(kMaxIdBytes);
  c->probe_serial = r->String(kMaxIdBytes);
  c->calibration_id = r->String(kMaxIdBytes);
  std::array<double, 16> h{};
  for (double& v : h) v = r->F64();
  std::string why;
  if (!base::PoseFromRowMajor(h, &c->mcs_from_flange, &why)) Bad("flange pose: " + why);
  c->first_frame_ns = static_cast<std::int64_t>(r->U64());
  c->last_frame_ns = static_cast<std::int64_t>(r->U64());
  c->processed_ns = static_cast<std::int64_t>(r->U64());
  c->edge = GetEdge(r);
  c->stripes = GetAccount(r);
  const std::size_t n = r->U32();
  if (n > kMaxCloudPoints) Bad("point count " + std::to_string(n) + " over the limit");
  return n;
}

}  // namespace

CloudHeader PeekCloud(const Bytes& payload) {
  Reader r(payload);
  CloudHeader h;
  h.points = ReadHeader(&r, &h.meta);
  return h;
}

CloudIds PeekCloudIds(const Bytes& payload) {
  Reader r(payload);
  CloudIds ids;
  ids.capture_id = r.String(kMaxIdBytes);
  ids.probe_serial = r.String(kMaxIdBytes);
  return ids;
}

LinkCloud DecodeCloud(const Bytes& payload) {
  Reader r(payload);
  LinkCloud c;
  const std::size_t n = ReadHeader(&r, &c);
  const std::size_t max_body = 3 * (4 + kMaxVarint * n) + n;  // three streams + quality
  const std::uint8_t method = r.U8();
  Bytes body;
  if (method == kRaw) {
    body = r.Blob(max_body);
  } else if (method == kZstd) {
    const std::size_t size = r.U32();
    if (size > max_body) Bad("stated body size over the limit for its point count");
    const Bytes packed = r.Blob(payload.size());
    // The frame's own content size must agree: no short body, no more than stated. The stated
    // size is bounded by the point count, not by the packed size (a 1.3 KB frame may unpack to
    // 128 MB): the host decodes only a cloud it asked for, of the probe it asked
    // (HostLink::SetAdmission), so a key's holder costs one legal cloud per request at most.
    const unsigned long long stated = ZSTD_getFrameContentSize(packed.data(), packed.size());
    if (stated != size) Bad("zstd frame size disagrees with the stated size");
    body.resize(size);
    const std::size_t got = ZSTD_decompress(body.data(), body.size(), packed.data(), packed.size());
    if (ZSTD_isError(got) || got != size) Bad("zstd data corrupt");
  } else {
    Bad("unknown encoding " + std::to_string(method));
  }
  r.ExpectEnd();
  ReadBody(body, &c, n);
  return c;
}

LinkCloud Quantised(const LinkCloud& cloud) { return DecodeCloud(EncodeCloud(cloud, false)); }

}  // namespace mlp::link
