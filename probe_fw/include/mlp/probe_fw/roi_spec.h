#pragma once
/// @file Region-of-interest requests as text (docs/CLI.md, the link's capture request): what
/// the host asks for and the firmware turns into a RowMask on the LED frame.

#include "mlp/probe_fw/frame.h"
#include "mlp/probe_fw/roi.h"
#include "mlp/probe_fw/stripe.h"

#include <optional>
#include <stdexcept>
#include <string>

namespace mlp::probe_fw {

/// A region or window request that cannot be carried out as given: its text is malformed, or
/// what it names is not in the frames. The message says which, for a person.
class RoiError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// ROI_SPEC: "full" (the whole AOI of the frames), "rect:x0,y0,width,height" (sensor pixels,
/// clipped to the AOI), "hole:x,y" (the hole around that pixel, found on the LED frame: an
/// annulus from 0.6 of its rim radius to 20 px outside the rim), "edge:x,y" (the straight edge
/// through the edge points within 60 px: a band of +-20 px along it) or "face:x,y" (the bright
/// face holding that pixel, eroded by 6 px). Throws RoiError.
RowMask ParseRoi(const std::string& spec, const Aoi& aoi, const Frame* led);

/// The region of a ROI_SPEC and, for "edge:x,y", the straight edge it was found from (which the
/// capture reports: seed 004's line from the LED frame).
struct RoiFound {
  RowMask mask;
  std::optional<LineEdgeRoi> edge;
};
RoiFound LocateRoi(const std::string& spec, const Aoi& aoi, const Frame* led);

/// "x0,y0,width,height" in sensor pixels. Throws RoiError.
Aoi ParseAoi(const std::string& text);

}  // namespace mlp::probe_fw
