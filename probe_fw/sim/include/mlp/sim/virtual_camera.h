#pragma once
/// @file The virtual probe behind the firmware's Camera interface: a capture request renders the
/// scene at the request's pose, AOI and sweep, so a virtual probe answers the host exactly as a
/// real one would (the frames go through the real firmware and the real link).

#include "mlp/probe_fw/agent.h"
#include "mlp/sim/render.h"

#include <cstdint>
#include <functional>
#include <memory>

namespace mlp::sim {

/// The exposure the probe model's photometry (noise.*_e) is given for: the link's default.
constexpr double kReferenceExposureUs = 100.0;
/// The LED frame's edge pixels are the mean of n x n rays over the pixel, as a real pixel
/// integrates its area (SweepOptions::led_supersampling).
constexpr int kServedLedSupersampling = 8;

/// Noise is seeded from `seed` and the capture id, so a repeated request renders the same
/// frames. The request's exposure scales every light by exposure_us / kReferenceExposureUs. The
/// camera looks at `projector` (a VirtualProjector the agent drives), which must outlive it:
/// each grab is the rendered frame of what the projector lights.
///
/// Where the flange truly is in the scene's frame: the request's H unless `true_pose` says
/// otherwise (a machine whose controller's kinematics are not the machine's: machine_world.h).
/// The cloud carries the request's H either way, as a real probe's would.
using TruePose = std::function<geometry::Pose3(const link::CaptureRequest&)>;
probe_fw::Camera MakeVirtualCamera(std::shared_ptr<const VirtualProbe> probe,
                                   std::uint64_t seed,
                                   const probe_fw::Projector& projector,
                                   TruePose true_pose = nullptr);

}  // namespace mlp::sim
