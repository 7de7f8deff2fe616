#pragma once
// A virtual probe on a real link for tests: a box scene seen by the reference probe, capture
// requests looking down at its top face, and a node that runs the probe's link and firmware loop
// on a thread (rendered frames -> real firmware -> real link).

#include "mlp/link/transport.h"
#include "mlp/probe_fw/agent.h"
#include "mlp/sim/render.h"
#include "mlp/sim/virtual_camera.h"

#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "test_data.h"

namespace mlp::link::testing {

using namespace std::chrono_literals;

inline const std::string kReferenceProbe =
    mlp::test::SourceDir() + "/samples/probes/reference_probe.json";

// A box whose top face is z = 0 in the MCS, seen by the reference probe looking down.
inline std::shared_ptr<const sim::VirtualProbe> BoxProbe(const std::string& serial) {
  sim::Scene s;
  s.workpiece = sim::MakeBox({-50, -50, -30}, {50, 50, 0}, 0.6);
  probe_fw::ProbeModel model = probe_fw::LoadProbeModel(kReferenceProbe);
  model.serial = serial;
  return std::make_shared<const sim::VirtualProbe>(model, s);
}

inline CaptureRequest TopRequest(const sim::VirtualProbe& probe,
                                 const std::string& id,
                                 double dx_mm,
                                 int aoi_px = 160) {
  CaptureRequest r;
  r.capture_id = id;
  r.aoi_width = r.aoi_height = static_cast<std::uint16_t>(aoi_px);
  r.aoi_x0 = static_cast<std::uint16_t>((probe.model().camera.width_px - aoi_px) / 2);
  r.aoi_y0 = static_cast<std::uint16_t>((probe.model().camera.height_px - aoi_px) / 2);
  // Looking down: the flange turned half a turn about X, 120 mm above the face.
  r.mcs_from_flange.matrix() << 1, 0, 0, 1 + dx_mm, 0, -1, 0, 2, 0, 0, -1, 120, 0, 0, 0, 1;
  sim::Capture c;
  c.mcs_from_flange = r.mcs_from_flange;
  probe.ColumnsReaching(c, {r.aoi_x0, r.aoi_y0, aoi_px, aoi_px}, &r.first_column, &r.last_column);
  r.column_step = 2.0;
  return r;
}

// A virtual probe on the link: its link, its firmware loop and the thread running it.
struct VirtualProbeNode {
  VirtualProbeNode(std::shared_ptr<const sim::VirtualProbe> p, ProbeLinkConfig cfg)
      : probe(std::move(p)),
        projector(probe->model().projector.columns - 1.0),
        link(cfg, [](const std::string&) {}),
        agent(probe->model(),
              &link,
              sim::MakeVirtualCamera(probe, 3, projector),
              &projector,
              [](const std::string&) {}) {
    link.SetStatusSource([] { return ProbeStatus{87, 36.5, 0, 0, 0, 0, 0}; });
    link.Start();
    thread = std::thread([this] { agent.Serve(stop); });
  }
  ~VirtualProbeNode() {
    stop = true;
    thread.join();
    link.Stop();
  }
  std::shared_ptr<const sim::VirtualProbe> probe;
  probe_fw::VirtualProjector projector;
  ProbeLink link;
  probe_fw::ProbeAgent agent;
  std::atomic<bool> stop{false};
  std::thread thread;
};

inline bool WaitConnected(const HostLink& host,
                          const std::string& serial,
                          std::chrono::milliseconds wait = 60s) {
  for (auto until = std::chrono::steady_clock::now() + wait;
       std::chrono::steady_clock::now() < until; std::this_thread::sleep_for(5ms)) {
    for (const auto& s : host.ConnectedProbes()) {
      if (s == serial) return true;
    }
  }
  return false;
}

}  // namespace mlp::link::testing
