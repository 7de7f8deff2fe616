#include "mlp/link/messages.h"

#include "mlp/base/pose.h"

#include <cmath>

namespace mlp::link {
namespace {

[[noreturn]] void Bad(const std::string& what) {
  throw LinkError(LinkFault::kMalformedPayload, what);
}

void CheckText(const std::string& s, std::size_t max_bytes, const char* what, bool required) {
  if (s.size() > max_bytes) Bad(std::string(what) + " longer than " + std::to_string(max_bytes));
  if (required && s.empty()) Bad(std::string(what) + " is empty");
  for (const char c : s) {
    if (static_cast<unsigned char>(c) < 0x20) Bad(std::string(what) + " holds a control byte");
  }
}

// H on the wire: 16 numbers row by row, a rigid transform (base/pose.h) or a malformed payload.
Eigen::Isometry3d CheckedPose(const std::array<double, 16>& row_major) {
  Eigen::Isometry3d pose;
  std::string why;
  if (!base::PoseFromRowMajor(row_major, &pose, &why)) Bad(why);
  return pose;
}

void Check(const CaptureRequest& r) {
  CheckText(r.capture_id, kMaxIdBytes, "capture id", true);
  CheckText(r.roi, kMaxRoiBytes, "ROI spec", true);
  if (r.aoi_width == 0 || r.aoi_height == 0) Bad("capture request: empty AOI");
  if (!(r.exposure_us > 0.0 && r.exposure_us <= 1e6)) Bad("exposure outside (0, 1e6] us");
  if (!(r.column_step > 0.0)) Bad("sweep column step must be > 0");
  if (!(r.last_column >= r.first_column)) Bad("sweep's last column before its first");
  if (SweepFrames(r) > kMaxSweepFrames)
    Bad("sweep of more than " + std::to_string(kMaxSweepFrames) + " frames");
  CheckedPose(base::RowMajor(r.mcs_from_flange));
}

void Check(const ProbeStatus& s) {
  if (s.battery_percent > 100) Bad("battery above 100 %");
  if (!(s.temperature_c >= -40.0 && s.temperature_c <= 125.0))
    Bad("temperature outside -40..125 C");
  if (s.buffer_used > s.buffer_capacity) Bad("buffer holds more than its capacity");
  if (s.flags & ~(kStatusBufferFull | kStatusBusy | kStatusCharging)) Bad("unknown status flag");
  if (s.last_error > 6) Bad("unknown last error code " + std::to_string(s.last_error));
}

void Check(const ProbeError& e) {
  const auto c = static_cast<std::uint16_t>(e.code);
  if (c < 1 || c > 6) Bad("unknown error code " + std::to_string(c));
  CheckText(e.capture_id, kMaxIdBytes, "capture id", false);
  CheckText(e.message, kMaxMessageBytes, "error message", false);
}

}  // namespace

const char* ToString(ProbeErrorCode code) {
  switch (code) {
    case ProbeErrorCode::kBufferFull:
      return "buffer_full";
    case ProbeErrorCode::kBadRequest:
      return "bad_request";
    case ProbeErrorCode::kCaptureFailed:
      return "capture_failed";
    case ProbeErrorCode::kOverTemperature:
      return "over_temperature";
    case ProbeErrorCode::kBatteryLow:
      return "battery_low";
    case ProbeErrorCode::kBusy:
      return "busy";
  }
  return "unknown";
}

std::uint32_t SweepFrames(const CaptureRequest& r) {
  const double n = std::floor((r.last_column - r.first_column) / r.column_step + 1e-9) + 1.0;
  if (!std::isfinite(n) || n < 1.0) return 0;
  return n > 4e9 ? 0xffffffffu : static_cast<std::uint32_t>(n);
}

Bytes Encode(const CaptureRequest& r) {
  Check(r);
  Bytes b;
  PutString(&b, r.capture_id);
  PutString(&b, r.roi);
  for (std::uint16_t v : {r.aoi_x0, r.aoi_y0, r.aoi_width, r.aoi_height}) PutU16(&b, v);
  for (double v : {r.exposure_us, r.first_column, r.last_column, r.column_step}) PutF64(&b, v);
  for (double v : base::RowMajor(r.mcs_from_flange)) PutF64(&b, v);
  return b;
}

CaptureRequest DecodeCaptureRequest(const Bytes& payload) {
  Reader in(payload);
  CaptureRequest r;
  r.capture_id = in.String(kMaxIdBytes);
  r.roi = in.String(kMaxRoiBytes);
  for (std::uint16_t* v : {&r.aoi_x0, &r.aoi_y0, &r.aoi_width, &r.aoi_height}) *v = in.U16();
  for (double* v : {&r.exposure_us, &r.first_column, &r.last_column, &r.column_step}) *v = in.F64();
  std::array<double, 16> h{};
  for (double& v : h) v = in.F64();
  r.mcs_from_flange = CheckedPose(h);
  in.ExpectEnd();
  Check(r);
  return r;
}

Bytes Encode(const ProbeStatus& s) {
  Check(s);
  Bytes b;
  PutU8(&b, s.battery_percent);
  PutF64(&b, s.temperature_c);
  PutU32(&b, s.buffer_used);
  PutU32(&b, s.buffer_capacity);
  PutU8(&b, s.flags);
  PutU32(&b, s.frames_dropped);
  PutU16(&b, s.last_error);
  return b;
}

ProbeStatus DecodeStatus(const Bytes& payload) {
  Reader in(payload);
  ProbeStatus s;
  s.battery_percent = in.U8();
  s.temperature_c = in.F64();
  s.buffer_used = in.U32();
  s.buffer_capacity = in.U32();
  s.flags = in.U8();
  s.frames_dropped = in.U32();
  s.last_error = in.U16();
  in.ExpectEnd();
  Check(s);
  return s;
}

Bytes Encode(const ProbeError& e) {
  Check(e);
  Bytes b;
  PutU16(&b, static_cast<std::uint16_t>(e.code));
  PutString(&b, e.capture_id);
  PutString(&b, e.message);
  return b;
}

ProbeError DecodeError(const Bytes& payload) {
  Reader in(payload);
  ProbeError e;
  e.code = static_cast<ProbeErrorCode>(in.U16());
  e.capture_id = in.String(kMaxIdBytes);
  e.message = in.String(kMaxMessageBytes);
  in.ExpectEnd();
  Check(e);
  return e;
}

Bytes EncodeAck(const std::string& capture_id) {
  CheckText(capture_id, kMaxIdBytes, "capture id", true);
  Bytes b;
  PutString(&b, capture_id);
  return b;
}

std::string DecodeAck(const Bytes& payload) {
  Reader in(payload);
  std::string id = in.String(kMaxIdBytes);
  in.ExpectEnd();
  CheckText(id, kMaxIdBytes, "capture id", true);
  return id;
}

}  // namespace mlp::link
