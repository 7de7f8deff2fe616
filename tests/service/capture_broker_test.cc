// Captures as calls over real loopback sockets: a job asks the broker for a cloud and gets it
// from the virtual probe (rendered frames, real firmware, real link), or a typed failure: probe
// not connected, the probe's own error, a timeout. A cloud that comes after its job gave up
// never reaches another job.

#include "mlp/service/capture_broker.h"

#include <future>

#include "link/link_test_util.h"
#include "link/virtual_probe_node.h"
#include <gtest/gtest.h>

namespace mlp::service {
namespace {

using namespace link::testing;
using namespace std::chrono_literals;

constexpr auto kRenderTimeout = 60s;  // a 160 x 160 px capture renders in well under a second
// Long enough for the test's second request to reach the broker while the first waits, on a
// busy machine too.
constexpr auto kSilentTimeout = 3s;

CaptureError::Kind KindOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const CaptureError& e) {
    return e.kind();
  }
  ADD_FAILURE() << "no CaptureError";
  return CaptureError::Kind::kBadRequest;
}

TEST(CaptureBroker, CloudsComeBackToTheJobThatAsked) {
  LogBook logs;
  CaptureBroker broker(HostConfig({{"VP-1", KeyOf(1)}}, 2000ms),
                       [&](const std::string& l) { logs.Log(l); });
  broker.Start();
  const auto probe = BoxProbe("VP-1");
  EXPECT_EQ(KindOf([&] { broker.Capture("VP-1", TopRequest(*probe, "early", 0), 1s); }),
            CaptureError::Kind::kProbeNotConnected);
  VirtualProbeNode node(probe, ProbeConfig("VP-1", KeyOf(1), broker.Port(), 2000ms));
  for (int i = 0; i < 600 && broker.ConnectedProbes().empty(); ++i)
    std::this_thread::sleep_for(10ms);
  ASSERT_EQ(broker.ConnectedProbes(), std::vector<std::string>{"VP-1"});

  // Two jobs at once: each gets its own cloud.
  auto a = std::async(std::launch::async, [&] {
    return broker.Capture("VP-1", TopRequest(*probe, "job-a", 0.0), kRenderTimeout);
  });
  auto b = std::async(std::launch::async, [&] {
    return broker.Capture("VP-1", TopRequest(*probe, "job-b", 4.0), kRenderTimeout);
  });
  const link::LinkCloud ca = a.get(), cb = b.get();
  EXPECT_EQ(ca.capture_id, "job-a");
  EXPECT_EQ(cb.capture_id, "job-b");
  EXPECT_EQ(cb.mcs_from_flange.translation().x(),
            5.0);  // H travelled with its capture (x = 1 + 4 mm)
  EXPECT_GT(ca.size(), 5000u);

  link::CaptureRequest bad = TopRequest(*probe, "bad", 0.0);
  bad.roi = "hole:1024,768";  // no hole on a flat face: the probe refuses with a reason
  try {
    broker.Capture("VP-1", bad, kRenderTimeout);
    ADD_FAILURE() << "no error";
  } catch (const CaptureError& e) {
    EXPECT_EQ(e.kind(), CaptureError::Kind::kProbeError);
    EXPECT_NE(std::string(e.what()).find("bad_request"), std::string::npos) << e.what();
  }
  link::CaptureRequest malformed = TopRequest(*probe, "malformed", 0.0);
  malformed.column_step = -1;
  EXPECT_EQ(KindOf([&] { broker.Capture("VP-1", malformed, 1s); }),
            CaptureError::Kind::kBadRequest);
  EXPECT_EQ(broker.LatestStatus("VP-1")->battery_percent, 87);
}

TEST(CaptureBroker, SilentProbesTimeOutAndLateCloudsAreDropped) {
  LogBook logs;
  CaptureBroker broker(HostConfig({{"VP-2", KeyOf(2)}}, 2000ms),
                       [&](const std::string& l) { logs.Log(l); });
  broker.Start();
  // A probe whose firmware never answers: only its link runs.
  link::ProbeLink silent(ProbeConfig("VP-2", KeyOf(2), broker.Port(), 2000ms),
                         [](const std::string&) {});
  silent.Start();
  for (int i = 0; i < 600 && broker.ConnectedProbes().empty(); ++i)
    std::this_thread::sleep_for(10ms);
  const auto probe = BoxProbe("VP-2");
  auto waiting = std::async(std::launch::async, [&] {
    return KindOf([&] { broker.Capture("VP-2", TopRequest(*probe, "slow", 0), kSilentTimeout); });
  });
  // The event, not a delay: the first request reached the probe, so the broker holds it.
  ASSERT_TRUE(silent.NextRequest(30s).has_value());
  // The same capture id again while the first waits: refused, the first is not disturbed.
  EXPECT_EQ(KindOf([&] { broker.Capture("VP-2", TopRequest(*probe, "slow", 0), 1s); }),
            CaptureError::Kind::kBadRequest);
  EXPECT_EQ(waiting.get(), CaptureError::Kind::kTimeout);
  // The cloud arrives after all: acknowledged by the link, never decoded (no job waits for it:
  // the broker's admission turns it away), logged.
  link::LinkCloud late;
  late.capture_id = "slow";
  late.probe_serial = "VP-2";
  late.xyz = {0, 0, 100};
  late.quality = {1.0f};
  ASSERT_EQ(silent.Submit(late), link::SubmitResult::kQueued);
  EXPECT_TRUE(silent.WaitAllAcknowledged(5s));
  EXPECT_TRUE(logs.Logged("cloud slow of probe VP-2 not taken: no job waits for this capture id"));
  silent.Stop();
}

}  // namespace
}  // namespace mlp::service
