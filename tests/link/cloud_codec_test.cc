// Cloud encoding: lossless to 0.1 um, bytes per point on a real firmware cloud, and hostile
// payloads rejected before they cost memory.

#include "mlp/link/cloud_codec.h"

#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <cmath>
#include <cstring>
#include <random>

#include "edge_sight_sample.h"
#include "test_data.h"
#include <gtest/gtest.h>

namespace mlp::link {
namespace {

constexpr double kLossMm = 0.5 * kResolutionMm;  // rounding to the 0.1 um grid
constexpr double kTargetBytesPerPoint = 4.0;     // issue 4, typical ROI cloud, compressed

const std::string kReference = mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

// A typical ROI cloud: the firmware's reconstruction of a 300 x 300 px face patch.
LinkCloud FirmwareCloud() {
  sim::Scene s;
  s.workpiece = sim::MakeBox({-50, -50, -30}, {50, 50, 0}, 0.6);
  sim::Capture c;
  c.mcs_from_flange.linear() = Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()).toRotationMatrix();
  c.mcs_from_flange.translation() = geometry::Vec3(1, 2, 120);
  s.captures.push_back(c);
  const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), s);
  sim::SweepOptions o;
  o.aoi = {874, 618, 300, 300};
  probe.ColumnsReaching(c, o.aoi, &o.first_column, &o.last_column);
  o.column_step = 2.0;
  const auto r = probe.Render(c, o);
  probe_fw::StripeCounts counts;
  const auto cloud = probe_fw::ReconstructSweep(probe.model(), r.laser,
                                                probe_fw::RowMask::Full(o.aoi), {}, &counts);
  LinkCloud out;
  out.capture_id = "face-1";
  out.probe_serial = probe.model().serial;
  out.calibration_id = probe.model().calibration_id;
  out.mcs_from_flange = c.mcs_from_flange;
  out.first_frame_ns = 1'000'000, out.last_frame_ns = 1'500'000, out.processed_ns = 1'700'000;
  for (const auto& p : cloud) {
    for (int a = 0; a < 3; ++a) out.xyz.push_back(p.point_in_probe(a));
    out.quality.push_back(static_cast<float>(p.quality));
  }
  return out;
}

void ExpectClose(const LinkCloud& a, const LinkCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  double worst = 0.0;
  for (size_t i = 0; i < a.xyz.size(); ++i) worst = std::max(worst, std::abs(a.xyz[i] - b.xyz[i]));
  EXPECT_LE(worst, kLossMm * (1 + 1e-9));
  for (size_t i = 0; i < a.size(); ++i) EXPECT_NEAR(a.quality[i], b.quality[i], 0.5 / 255.0 + 1e-7);
  EXPECT_EQ(a.capture_id, b.capture_id);
  EXPECT_TRUE(a.mcs_from_flange.matrix() == b.mcs_from_flange.matrix());  // exact
  EXPECT_EQ(a.last_frame_ns, b.last_frame_ns);
  EXPECT_EQ(a.processed_ns, b.processed_ns);
}

TEST(CloudCodec, FirmwareCloudUnderFourBytesPerPointWithoutLoss) {
  const LinkCloud cloud = FirmwareCloud();
  ASSERT_GT(cloud.size(), 20000u);
  const Bytes raw = EncodeCloud(cloud, false), packed = EncodeCloud(cloud, true);
  const double raw_bpp = static_cast<double>(raw.size()) / static_cast<double>(cloud.size());
  const double packed_bpp = static_cast<double>(packed.size()) / static_cast<double>(cloud.size());
  std::printf("cloud of %zu points: %.2f bytes/point raw varints, %.2f with zstd\n", cloud.size(),
              raw_bpp, packed_bpp);
  EXPECT_LT(packed_bpp, kTargetBytesPerPoint);
  ExpectClose(cloud, DecodeCloud(raw));
  ExpectClose(cloud, DecodeCloud(packed));
  // Bit-exact after the first quantisation: decoding twice changes nothing.
  const LinkCloud q = Quantised(cloud);
  EXPECT_EQ(DecodeCloud(EncodeCloud(q, true)).xyz, q.xyz);
}

// An edge as the firmware reports it: a plane through the camera centre, rays in it.
base::EdgeSight TestEdge() { return test::SampleEdgeSight(); }

// Link version 3: the LED frame's edge rides with the cloud, exactly; an edge that is not one
// is refused on encode and on decode.
TEST(CloudCodec, TheLedFramesEdgeRidesAlongExactly) {
  LinkCloud c;
  c.xyz = {1, 2, 3};
  c.quality = {0.5f};
  c.edge = TestEdge();
  for (bool compress : {false, true}) {
    const LinkCloud d = DecodeCloud(EncodeCloud(c, compress));
    ASSERT_TRUE(d.edge);
    EXPECT_TRUE(d.edge->normal_in_probe == c.edge->normal_in_probe);
    EXPECT_TRUE(d.edge->first_ray_in_probe == c.edge->first_ray_in_probe);
    EXPECT_TRUE(d.edge->last_ray_in_probe == c.edge->last_ray_in_probe);
    EXPECT_EQ(d.edge->rms_px, c.edge->rms_px);
    EXPECT_EQ(d.edge->points, c.edge->points);
  }
  c.edge.reset();
  EXPECT_FALSE(DecodeCloud(EncodeCloud(c, false)).edge);
  c.edge = TestEdge();
  c.edge->first_ray_in_probe = -c.edge->first_ray_in_probe;  // behind the camera
  try {
    EncodeCloud(c, false);
    ADD_FAILURE() << "an edge behind the camera was encoded";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("behind the camera"), std::string::npos) << e.what();
  }
  // The same on decode: the normal's first number made 2 in the bytes (it follows the three
  // strings, the pose, three timestamps and the presence byte).
  c.edge = TestEdge();
  Bytes b = EncodeCloud(c, false);
  const size_t normal_at = 3 * 2 + 16 * 8 + 3 * 8 + 1;
  const double two = 2.0;
  std::memcpy(&b[normal_at], &two, sizeof two);
  try {
    DecodeCloud(b);
    ADD_FAILURE() << "a normal of length 2 was decoded";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("unit length"), std::string::npos) << e.what();
  }
}

// Issue 50 item 5: the firmware's account of the stripe's light rides along, and a count no
// sensor could make is refused. It follows the edge's presence byte (no edge here).
TEST(CloudCodec, TheStripeAccountRidesAlongAndAnImpossibleCountIsRefused) {
  LinkCloud c;
  c.xyz = {1, 2, 3};
  c.quality = {0.5f};
  c.stripes.kept = 1, c.stripes.weak = 2, c.stripes.cut = 3, c.stripes.saturated = 4;
  c.stripes.double_peak = 5, c.stripes.too_wide = 6, c.stripes.too_narrow = 7;
  c.stripes.indirect = 8, c.stripes.second_on_line = 9, c.stripes.undecided_on_line = 10;
  c.stripes.beside_rejected = 11, c.stripes.reflectance = 12, c.stripes.isolated = 13;
  for (bool compress : {false, true}) {
    const StripeAccount d = DecodeCloud(EncodeCloud(c, compress)).stripes;
    EXPECT_EQ(d.kept, 1u);
    EXPECT_EQ(d.weak + d.cut, 5u);
    EXPECT_EQ(d.reflectance, 12u);
    EXPECT_EQ(d.beside_rejected, 11u);
    EXPECT_EQ(d.isolated, 13u);
    // Rejected light: 4 + 5 + ... + 13 = 85 of 86 (weak and cut are not stripe light).
    EXPECT_DOUBLE_EQ(d.RejectedShare(), 85.0 / 86.0);
  }
  EXPECT_EQ(StripeAccount{}.RejectedShare(), 0.0);
  Bytes b = EncodeCloud(c, false);
  const size_t account_at = 3 * 2 + 16 * 8 + 3 * 8 + 1;  // strings, pose, times, edge byte
  ASSERT_EQ(b[account_at], 13);
  b[account_at + 1 + 8 * 4 + 7] = 0xff;  // the double-peak count's top byte: beyond 2^40
  try {
    DecodeCloud(b);
    ADD_FAILURE() << "a count of 2^63 was decoded";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("over 2^40"), std::string::npos) << e.what();
  }
  b[account_at] = 12;
  EXPECT_THROW(DecodeCloud(b), LinkError);
}

// Issue 48 item 11: an edge point count of 0xFFFFFFFF passed the link and became -1 further on,
// failing every later job on that capture. The count follows the edge's ten numbers.
TEST(CloudCodec, AnEdgeOfMoreThanASensorsPointsIsRefused) {
  LinkCloud c;
  c.xyz = {1, 2, 3};
  c.quality = {0.5f};
  c.edge = TestEdge();
  c.edge->points = base::kMaxEdgePoints;
  EXPECT_EQ(DecodeCloud(EncodeCloud(c, false)).edge->points, base::kMaxEdgePoints);
  c.edge->points = 0xffffffffu;
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
  c.edge->points = 100;
  Bytes b = EncodeCloud(c, false);
  const size_t count_at = 3 * 2 + 16 * 8 + 3 * 8 + 1 + 10 * 8;
  for (size_t k = 0; k < 4; ++k) b[count_at + k] = 0xff;
  try {
    DecodeCloud(b);
    ADD_FAILURE() << "an edge of 0xFFFFFFFF points was decoded";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("more than 65535 points"), std::string::npos) << e.what();
  }
}

// The host reads a cloud's header before deciding to decode it: the same metadata and count as
// the whole decode, from a payload whose points it never unpacks.
TEST(CloudCodec, TheHeaderAloneTellsWhoseCaptureAndHowMany) {
  LinkCloud c;
  c.capture_id = "vmc-1-7-top";
  c.probe_serial = "MLP-REF-0001";
  c.calibration_id = "cal-3";
  c.mcs_from_flange.translation() = Eigen::Vector3d(1, 2, 3);
  c.edge = TestEdge();
  c.xyz.assign(3 * 5000, 2.5);
  c.quality.assign(5000, 0.5f);
  Bytes b = EncodeCloud(c, true);
  const CloudHeader h = PeekCloud(b);
  EXPECT_EQ(h.meta.capture_id, c.capture_id);
  EXPECT_EQ(h.meta.probe_serial, c.probe_serial);
  EXPECT_EQ(h.meta.calibration_id, c.calibration_id);
  EXPECT_TRUE(h.meta.mcs_from_flange.isApprox(c.mcs_from_flange, 0.0));
  EXPECT_EQ(h.points, 5000u);
  EXPECT_TRUE(h.meta.xyz.empty());
  b.back() ^= 0xff;  // the packed points: the header does not read them
  EXPECT_EQ(PeekCloud(b).points, 5000u);
  EXPECT_THROW(DecodeCloud(b), LinkError);
}

TEST(CloudCodec, BadCloudsAreRefusedOnEncode) {
  LinkCloud c;
  c.xyz = {0, 0, 1e9};  // 1000 km
  c.quality = {0.5f};
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
  c.xyz = {0, 0, NAN};
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
  c.xyz = {0, 0, 1};
  c.quality = {1.5f};
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
  c.quality = {};
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
  c.quality = {0.5f};
  c.capture_id = std::string(257, 'x');  // the host would refuse it: refused here already
  EXPECT_THROW(EncodeCloud(c, false), LinkError);
}

TEST(CloudCodec, HostilePayloadsAreTypedErrors) {
  LinkCloud c;
  c.xyz = {1, 2, 3, 4, 5, 6};
  c.quality = {0.1f, 0.9f};
  c.edge = TestEdge();
  const Bytes good = EncodeCloud(c, true);
  // Every truncation and every single-byte change either decodes to a consistent cloud or throws
  // LinkError: never a crash, never an exception of another type.
  for (size_t cut = 0; cut < good.size(); ++cut) {
    EXPECT_THROW(DecodeCloud(Bytes(good.begin(), good.begin() + static_cast<long>(cut))),
                 LinkError);
  }
  for (size_t i = 0; i < good.size(); ++i) {
    Bytes b = good;
    b[i] ^= 0xff;
    try {
      const LinkCloud d = DecodeCloud(b);
      EXPECT_EQ(d.xyz.size(), 3 * d.quality.size());
    } catch (const LinkError&) {
    }
  }
  // A point count of 8 million with no data: refused without allocating for it.
  // Layout of an empty raw cloud's tail: count u32 | method u8 | body length u32 | body (three
  // empty streams: 12 bytes).
  Bytes bomb = EncodeCloud(LinkCloud{}, false);
  const size_t count_at = bomb.size() - 12 - 4 - 1 - 4;
  bomb[count_at + 2] = 0x81;  // 8,454,144 points: over the limit
  try {
    DecodeCloud(bomb);
    ADD_FAILURE() << "accepted";
  } catch (const LinkError& e) {
    EXPECT_NE(std::string(e.what()).find("point count"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mlp::link
