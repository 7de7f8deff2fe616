#pragma once
/// @file `mlp demo` (program mlp-demo, which `mlp demo` runs): the whole job on the virtual
/// machine. Starts mlp-hostd and a virtual probe (`mlp-sim serve`) on the demo plate
/// (samples/scenes/demo_plate.json), then as an NC program would: hand-eye calibration on the
/// reference sphere, plane-circle-circle alignment -> G54, the bore measured before its
/// finishing pass -> the finishing tool's radius offset; writes the tool table and the result
/// subroutine and prints what it found against the scene's truth.

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::sim {
class VirtualProbe;
struct Capture;
}  // namespace mlp::sim
namespace mlp::probe_fw {
struct Aoi;
}  // namespace mlp::probe_fw

namespace mlp::host {

/// A capture request for one of a scene's captures on `machine`: its pose, the AOI, and every
/// second projector column that reaches the scene there. The demo and the host's tests send it.
nlohmann::json SceneCaptureRequest(const std::string& machine,
                                   const sim::VirtualProbe& probe,
                                   const sim::Capture& capture,
                                   const probe_fw::Aoi& aoi);

/// The demo plate's plane-circle-circle alignment into G54 on `machine`, from the capture jobs
/// of face A and holes B and C, with the origin a setter expects (the part's placement rounded
/// to a millimetre, without its rotation). The demo and the host's tests send this request.
nlohmann::json DemoPlateAlignRequest(const std::string& machine,
                                     const std::vector<std::int64_t>& face,
                                     const std::vector<std::int64_t>& hole_b,
                                     const std::vector<std::int64_t>& hole_c);

int RunDemoCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
