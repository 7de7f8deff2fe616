// Capture requests, status and error messages: round trips, and every out-of-range value refused
// on encode and on decode.

#include "mlp/link/messages.h"

#include <random>

#include "link_test_util.h"
#include <gtest/gtest.h>

namespace mlp::link {
namespace {

using namespace testing;

CaptureRequest GoodRequest() {
  CaptureRequest r;
  r.capture_id = "job-7/bore-1";
  r.roi = "hole:1020,760";
  r.aoi_x0 = 512, r.aoi_y0 = 256, r.aoi_width = 1024, r.aoi_height = 1024;
  r.exposure_us = 250.0;
  r.first_column = 100.0, r.last_column = 900.0, r.column_step = 2.0;
  const double c = std::cos(0.3), s = std::sin(0.3);
  r.mcs_from_flange.matrix() << c, -s, 0, 10.5, s, c, 0, -20.25, 0, 0, 1, 300.125, 0, 0, 0, 1;
  return r;
}

TEST(Messages, RoundTripsAreExact) {
  const CaptureRequest r = GoodRequest();
  const CaptureRequest back = DecodeCaptureRequest(Encode(r));
  EXPECT_EQ(back.capture_id, r.capture_id);
  EXPECT_EQ(back.roi, r.roi);
  EXPECT_EQ(back.aoi_width, r.aoi_width);
  EXPECT_TRUE(back.mcs_from_flange.matrix() == r.mcs_from_flange.matrix());  // exact
  EXPECT_EQ(back.column_step, r.column_step);
  EXPECT_EQ(SweepFrames(r), 401u);

  const ProbeStatus s{17, 41.5, 3, 64, kStatusBusy, 12, 3};
  const ProbeStatus sb = DecodeStatus(Encode(s));
  EXPECT_EQ(sb.battery_percent, 17);
  EXPECT_EQ(sb.temperature_c, 41.5);
  EXPECT_EQ(sb.buffer_used, 3u);
  EXPECT_EQ(sb.flags, kStatusBusy);
  EXPECT_EQ(sb.frames_dropped, 12u);
  EXPECT_EQ(sb.last_error, 3);

  const ProbeError e{ProbeErrorCode::kBufferFull, "job-7/bore-1", "64 clouds wait"};
  const ProbeError eb = DecodeError(Encode(e));
  EXPECT_EQ(eb.code, e.code);
  EXPECT_EQ(eb.message, e.message);
  EXPECT_EQ(DecodeAck(EncodeAck("x")), "x");
}

TEST(Messages, RequestsThatCannotBeCarriedOutAreRefusedBeforeSending) {
  const std::vector<std::function<void(CaptureRequest*)>> defects = {
      [](CaptureRequest* r) { r->capture_id.clear(); },
      [](CaptureRequest* r) { r->capture_id = std::string(kMaxIdBytes + 1, 'a'); },
      [](CaptureRequest* r) { r->capture_id = "a\nb"; },
      [](CaptureRequest* r) { r->roi.clear(); },
      [](CaptureRequest* r) { r->aoi_width = 0; },
      [](CaptureRequest* r) { r->exposure_us = 0.0; },
      [](CaptureRequest* r) { r->exposure_us = 2e6; },
      [](CaptureRequest* r) { r->column_step = 0.0; },
      [](CaptureRequest* r) { r->last_column = r->first_column - 1; },
      [](CaptureRequest* r) { r->column_step = 0.01; },  // 80001 frames
      [](CaptureRequest* r) { r->mcs_from_flange.matrix()(0, 0) = NAN; },
      [](CaptureRequest* r) { r->mcs_from_flange.matrix()(3, 3) = 2.0; },
      [](CaptureRequest* r) { r->mcs_from_flange.matrix()(0, 0) = 1.1; },   // scaled
      [](CaptureRequest* r) { r->mcs_from_flange.matrix()(2, 2) = -1.0; },  // a reflection
  };
  for (size_t i = 0; i < defects.size(); ++i) {
    CaptureRequest r = GoodRequest();
    defects[i](&r);
    EXPECT_EQ(FaultOf([&] { Encode(r); }), LinkFault::kMalformedPayload) << "defect " << i;
  }
}

TEST(Messages, OutOfRangeStatusAndErrorsAreRefused) {
  EXPECT_EQ(FaultOf([] { Encode(ProbeStatus{101, 25, 0, 1, 0}); }), LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] { Encode(ProbeStatus{50, 200, 0, 1, 0}); }), LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] { Encode(ProbeStatus{50, 25, 5, 4, 0}); }), LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] { Encode(ProbeStatus{50, 25, 0, 4, 0x80}); }), LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] {
              Encode(ProbeStatus{50, 25, 0, 4, 0, 0, 7});
            }),
            LinkFault::kMalformedPayload);  // no such error code
  EXPECT_EQ(FaultOf([] {
              Encode(ProbeError{static_cast<ProbeErrorCode>(99), "", ""});
            }),
            LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] {
              Encode(ProbeError{ProbeErrorCode::kBusy, "", std::string(2000, 'x')});
            }),
            LinkFault::kMalformedPayload);
  EXPECT_EQ(FaultOf([] { EncodeAck(""); }), LinkFault::kMalformedPayload);
}

// Every truncation and random mutation of a valid payload decodes to a valid message or a typed
// error, never anything else (the messages' own small fuzz; the frame parser has libFuzzer).
TEST(Messages, HostilePayloadsDecodeOrFailTyped) {
  const std::vector<Bytes> payloads = {Encode(GoodRequest()),
                                       Encode(ProbeStatus{17, 41.5, 3, 64, kStatusBusy}),
                                       Encode(ProbeError{ProbeErrorCode::kBusy, "id", "text"})};
  const std::vector<std::function<void(const Bytes&)>> decoders = {
      [](const Bytes& b) { DecodeCaptureRequest(b); }, [](const Bytes& b) { DecodeStatus(b); },
      [](const Bytes& b) { DecodeError(b); }};
  std::mt19937 gen(4);
  int refused = 0, accepted = 0;
  for (size_t k = 0; k < payloads.size(); ++k) {
    for (size_t cut = 0; cut < payloads[k].size(); ++cut) {
      const Bytes b(payloads[k].begin(), payloads[k].begin() + static_cast<long>(cut));
      EXPECT_EQ(FaultOf([&] { decoders[k](b); }), LinkFault::kMalformedPayload);
    }
    for (int trial = 0; trial < 2000; ++trial) {
      Bytes b = payloads[k];
      b[gen() % b.size()] ^= static_cast<std::uint8_t>(1 + gen() % 255);
      try {
        decoders[k](b);
        ++accepted;
      } catch (const LinkError& e) {
        EXPECT_EQ(e.fault(), LinkFault::kMalformedPayload);
        ++refused;
      }
    }
  }
  EXPECT_GT(refused, 1000);  // most mutations break a checked field
  EXPECT_GT(accepted, 100);  // and the rest decode to messages that pass every check
}

}  // namespace
}  // namespace mlp::link
