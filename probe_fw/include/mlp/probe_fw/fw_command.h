#pragma once
/// @file `mlp-fw run`: frames (a capture directory or a V4L2 camera) -> ROI -> stripe centres ->
/// triangulation -> PLY cloud in the probe frame. docs/CLI.md has the contract.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/stripe.h"

#include <ostream>
#include <string>
#include <vector>

namespace mlp::probe_fw {

/// ROI_SPEC: "full" (the whole AOI of the frames), "rect:x0,y0,width,height" (sensor pixels,
/// clipped to the AOI), "hole:x,y" (the hole around that pixel, found on the LED frame: an
/// annulus from 0.6 of its rim radius to 20 px outside the rim), "edge:x,y" (the straight edge
/// through the edge points within 60 px: a band of +-20 px along it) or "face:x,y" (the bright
/// face holding that pixel, eroded by 6 px). Throws cli::UsageError.
RowMask ParseRoi(const std::string& spec, const Aoi& aoi, const Frame* led);

/// Runs `mlp-fw <args>`; returns the exit code (cli::kExit*).
int RunFwCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::probe_fw
