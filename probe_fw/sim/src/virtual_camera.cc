#include "mlp/sim/virtual_camera.h"

#include <functional>
#include <stdexcept>
#include <utility>

namespace mlp::sim {

probe_fw::Camera MakeVirtualCamera(std::shared_ptr<const VirtualProbe> probe,
                                   std::uint64_t seed,
                                   const probe_fw::Projector& projector,
                                   TruePose true_pose) {
  return [probe = std::move(probe), seed, &projector, true_pose = std::move(true_pose)](
             const link::CaptureRequest& r, const probe_fw::SweepPlan& plan) {
    Capture capture;
    capture.id = r.capture_id;
    capture.mcs_from_flange = true_pose ? true_pose(r) : r.mcs_from_flange;
    SweepOptions o;
    o.aoi = plan.aoi;
    o.first_column = plan.columns.front();
    o.last_column = plan.columns.back();
    o.column_step = r.column_step;
    o.seed = seed ^ std::hash<std::string>{}(r.capture_id);
    // A real pixel integrates its whole area: sampled at its centre only, an edge along the
    // pixel rows reads whole pixels (13 um steps at 120 mm) and its slope vanishes.
    o.led_supersampling = kServedLedSupersampling;
    // The model's photometry is that of the link's default exposure: a longer one (dark metal)
    // collects proportionally more light, and clips sooner on a glint.
    o.exposure = plan.exposure_us / kReferenceExposureUs;
    // A sweep the sensor or the projector cannot make throws RequestError: the request, not
    // the camera, is at fault.
    RenderedCapture rendered = probe->Render(capture, o);
    // The rendered sweep is what the camera sees; the projector the agent drives picks the
    // frame of each exposure.
    std::vector<probe_fw::Frame> frames{std::move(rendered.led)};
    for (probe_fw::Frame& f : rendered.laser) frames.push_back(std::move(f));
    return probe_fw::MakeRecordedCamera(std::move(frames), projector);
  };
}

}  // namespace mlp::sim
