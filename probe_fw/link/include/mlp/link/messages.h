#pragma once
/// @file The link's small messages (docs/LINK.md): CAPTURE_REQUEST (host -> probe), STATUS and
/// ERROR (probe -> host), ACK (host -> probe). CLOUD is cloud_codec.h's. Every field is checked
/// on both encode and decode: a message that would be refused on arrival is refused before it is
/// sent, and a decoded message always holds values the firmware can act on.

#include "mlp/link/wire.h"

#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Geometry>

namespace mlp::link {

constexpr std::size_t kMaxRoiBytes = 128;       ///< "full", "rect:X,Y,W,H", "hole:X,Y", ...
constexpr std::size_t kMaxMessageBytes = 1024;  ///< an error's text
constexpr std::uint32_t kMaxSweepFrames = 8192;

/// What the host asks the probe to capture. The probe captures at standstill: the pose is the
/// machine's position while the sweep runs, passed along so the cloud carries it.
struct CaptureRequest {
  std::string capture_id;    ///< chosen by the host; the cloud comes back under it
  std::string roi = "full";  ///< the firmware's ROI spec (docs/PROBE.md), checked by the probe
  std::uint16_t aoi_x0 = 0, aoi_y0 = 0, aoi_width = 0, aoi_height = 0;  ///< sensor window [px]
  double exposure_us = 100.0;                                           ///< per frame, (0, 1e6]
  double first_column = 0.0;  ///< projector columns of the sweep, inclusive
  double last_column = 0.0;
  double column_step = 1.0;  ///< > 0; at most kMaxSweepFrames laser frames
  /// H at capture; on the wire 16 numbers row by row (base/pose.h)
  Eigen::Isometry3d mcs_from_flange = Eigen::Isometry3d::Identity();
};

enum StatusFlags : std::uint8_t {
  kStatusBufferFull = 1,  ///< new captures are refused until the host acknowledges clouds
  kStatusBusy = 2,        ///< a capture is running
  kStatusCharging = 4,
};

struct ProbeStatus {
  std::uint8_t battery_percent = 100;  ///< 0..100
  double temperature_c = 25.0;         ///< board temperature, -40..125
  std::uint32_t buffer_used = 0;       ///< clouds waiting for the host's acknowledgement
  std::uint32_t buffer_capacity = 0;
  std::uint8_t flags = 0;            ///< StatusFlags
  std::uint32_t frames_dropped = 0;  ///< by the camera since the probe started
  std::uint16_t last_error = 0;      ///< ProbeErrorCode of the last failed request, 0: none
};

enum class ProbeErrorCode : std::uint16_t {
  kBufferFull = 1,     ///< the capture was refused: the store-and-forward buffer is full
  kBadRequest = 2,     ///< the request cannot be carried out as given (ROI, AOI, sweep)
  kCaptureFailed = 3,  ///< camera or reconstruction failed
  kOverTemperature = 4,
  kBatteryLow = 5,
  kBusy = 6,  ///< the probe still works on earlier requests; ask again later
};

const char* ToString(ProbeErrorCode code);

struct ProbeError {
  ProbeErrorCode code = ProbeErrorCode::kCaptureFailed;
  std::string capture_id;  ///< the request it answers; empty when it answers none
  std::string message;     ///< for a person: what went wrong and what to do
};

/// Encoders throw LinkError (kMalformedPayload) on a value outside its range, decoders on any
/// inconsistency (short, trailing bytes, range, non-finite numbers).
Bytes Encode(const CaptureRequest& request);
CaptureRequest DecodeCaptureRequest(const Bytes& payload);
Bytes Encode(const ProbeStatus& status);
ProbeStatus DecodeStatus(const Bytes& payload);
Bytes Encode(const ProbeError& error);
ProbeError DecodeError(const Bytes& payload);
/// ACK: the capture id received.
Bytes EncodeAck(const std::string& capture_id);
std::string DecodeAck(const Bytes& payload);

/// Number of laser frames of the request's sweep.
std::uint32_t SweepFrames(const CaptureRequest& request);

}  // namespace mlp::link
