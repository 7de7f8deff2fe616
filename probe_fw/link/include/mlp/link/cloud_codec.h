#pragma once
/// @file A cloud and its capture metadata as a CLOUD payload (docs/LINK.md): coordinates
/// quantised to 0.1 um (int32: +-214 m), each axis delta-coded against the previous point,
/// zig-zag varints in separate streams per axis, quality in 8 bits, then optionally zstd.
/// Decoding reproduces the quantised cloud bit for bit; every coordinate is within 0.05 um of
/// the original.

#include "mlp/base/edge_sight.h"
#include "mlp/link/wire.h"

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace mlp::link {

constexpr double kResolutionMm = 1e-4;
/// Points in one cloud at most (a full 2048 x 1536 sweep of 1024 lines is ~3e6).
constexpr std::uint32_t kMaxCloudPoints = 8u << 20;

/// What the firmware did with the stripe's candidates in a capture (since link version 4): the
/// points kept and each rejection by its reason (probe_fw/stripe.h, StripeCounts). The host
/// refuses to act on a capture whose stripe light was mostly rejected (docs/HOSTD.md).
struct StripeAccount {
  std::uint64_t kept = 0;
  /// Not stripe light: below the threshold, or cut by the ROI's edge.
  std::uint64_t weak = 0, cut = 0;
  /// Stripe light the firmware would not measure: saturated, double-peaked, too wide, too
  /// narrow, reflections (told by the sweep, or a second candidate on an epipolar line),
  /// undecided between two, beside a brighter rejected stripe, reflectance too uneven, on a
  /// trace of a few lines.
  std::uint64_t saturated = 0, double_peak = 0, too_wide = 0, too_narrow = 0, indirect = 0,
                second_on_line = 0, undecided_on_line = 0, beside_rejected = 0, reflectance = 0,
                isolated = 0;
  /// The rejected stripe light over all stripe light (kept + rejected), 0 when there was none.
  double RejectedShare() const;
};

struct LinkCloud {
  std::string capture_id;
  std::string probe_serial;
  std::string calibration_id;
  /// H at capture; on the wire 16 numbers row by row (base/pose.h)
  Eigen::Isometry3d mcs_from_flange = Eigen::Isometry3d::Identity();
  /// The acquisition on the probe's clock [ns]: from arming the camera for the first frame (a
  /// virtual probe renders then) to the last frame in.
  std::int64_t first_frame_ns = 0;
  std::int64_t last_frame_ns = 0;
  /// When the firmware had the cloud ready (after triangulation), on the probe's clock: with
  /// the frame times it splits a capture's time into frames and firmware, the rest of the
  /// host's round trip being the link's.
  std::int64_t processed_ns = 0;
  /// The straight edge the firmware found on the LED frame for an `edge:X,Y` ROI (since link
  /// version 3); empty for other ROIs.
  std::optional<base::EdgeSight> edge;
  StripeAccount stripes;
  std::vector<double> xyz;     ///< x y z per point [mm], probe frame
  std::vector<float> quality;  ///< 0..1 per point
  std::size_t size() const { return quality.size(); }
};

/// Throws LinkError (kMalformedPayload) for a coordinate beyond int32 at 0.1 um, NaN, a
/// quality outside 0..1, mismatched sizes or an edge that is not one (base::EdgeSightFromNumbers).
Bytes EncodeCloud(const LinkCloud& cloud, bool compress);
/// Throws LinkError (kMalformedPayload) on anything inconsistent, before allocating more than
/// the stated point count allows.
LinkCloud DecodeCloud(const Bytes& payload);

/// A CLOUD's metadata and stated point count without its points: what the host checks against
/// the request that asked for the capture before it decompresses and decodes anything (a
/// 1.3 KB zstd frame may state 8M points: 350 MB once decoded). Throws as DecodeCloud does on
/// the part it reads.
struct CloudHeader {
  LinkCloud meta;  ///< everything but xyz and quality, which are empty
  std::size_t points = 0;
};
CloudHeader PeekCloud(const Bytes& payload);
/// The capture id and the probe serial alone (the payload's first two fields): what the host
/// needs to answer a capture whose cloud is malformed further on. Throws when even they are not
/// there.
struct CloudIds {
  std::string capture_id, probe_serial;
};
CloudIds PeekCloudIds(const Bytes& payload);

/// The cloud after a round trip: coordinates on the 0.1 um grid, quality on 8 bits.
LinkCloud Quantised(const LinkCloud& cloud);

}  // namespace mlp::link
