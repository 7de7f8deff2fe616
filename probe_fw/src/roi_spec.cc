#include "mlp/probe_fw/roi_spec.h"

#include "mlp/probe_fw/roi.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace mlp::probe_fw {
namespace {

// "X,Y" in sensor pixels.
Vec2 ParseHint(const std::string& text, const std::string& spec) {
  double x = 0, y = 0;
  char comma = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c", &x, &comma, &y, &extra) != 3 || comma != ',') {
    throw RoiError("the hint of " + spec + " is X,Y in sensor pixels");
  }
  return {x, y};
}

// Hole ROI: from 0.6 of the rim radius (the wall seen inside the rim) to 20 px outside it (the
// face around the rim).
constexpr double kHoleInner = 0.6;
constexpr double kHoleOuterPx = 20.0;
// Edge ROI: edge points within 60 px of the hint make the line; the ROI is a band of +-20 px.
constexpr double kEdgeSearchPx = 60.0;
constexpr double kEdgeBandPx = 20.0;
// Face ROI: eroded so that stripe windows (+-6 px) stay on the face.
constexpr int kFaceErodePx = 6;

}  // namespace

RowMask ParseRoi(const std::string& spec, const Aoi& aoi, const Frame* led) {
  return LocateRoi(spec, aoi, led).mask;
}

RoiFound LocateRoi(const std::string& spec, const Aoi& aoi, const Frame* led) {
  if (spec == "full") return {RowMask::Full(aoi), std::nullopt};
  const bool hole = spec.rfind("hole:", 0) == 0, face = spec.rfind("face:", 0) == 0;
  const bool edge = spec.rfind("edge:", 0) == 0;
  if (hole || face || edge) {
    if (led == nullptr) throw RoiError(spec + " needs the LED frame, and the capture has none");
    if (led->aoi.x0 != aoi.x0 || led->aoi.y0 != aoi.y0 || led->aoi.width != aoi.width ||
        led->aoi.height != aoi.height) {
      throw RoiError("the LED frame's AOI differs from the laser frames'");
    }
    const Vec2 hint = ParseHint(spec.substr(5), spec);
    RowMask m;
    std::optional<LineEdgeRoi> line;
    if (hole) {
      const auto found = FindHole(*led, hint, 10.0, 2.0 * std::max(aoi.width, aoi.height));
      if (!found) throw RoiError("no hole around " + spec.substr(5) + " in the LED frame");
      m = AnnulusMask(aoi, found->center_px, kHoleInner * found->radius_px,
                      found->radius_px + kHoleOuterPx);
    } else if (edge) {
      const auto found = FindLineEdge(*led, hint, kEdgeSearchPx);
      if (!found) throw RoiError("no straight edge near " + spec.substr(5) + " in the LED frame");
      m = BandMask(aoi, found->point_px, found->direction, kEdgeBandPx);
      line = found;
    } else {
      m = FaceMask(*led, hint, kFaceErodePx);
    }
    if (m.PixelCount() == 0) throw RoiError("the ROI " + spec + " holds no pixel of the AOI");
    return {m, line};
  }
  if (spec.rfind("rect:", 0) == 0) {
    const Aoi r = ParseAoi(spec.substr(5));
    RowMask m;
    m.aoi = aoi;
    m.rows.resize(static_cast<size_t>(aoi.height));
    const int b = std::max(0, r.x0 - aoi.x0), e = std::min(aoi.width, r.x0 + r.width - aoi.x0);
    size_t pixels = 0;
    for (int y = std::max(0, r.y0 - aoi.y0); y < std::min(aoi.height, r.y0 + r.height - aoi.y0);
         ++y) {
      if (e > b)
        m.rows[static_cast<size_t>(y)].push_back({b, e}), pixels += static_cast<size_t>(e - b);
    }
    if (pixels == 0) throw RoiError("the ROI " + spec + " does not overlap the frames' AOI");
    return {m, std::nullopt};
  }
  throw RoiError("ROI_SPEC is full or rect:X0,Y0,W,H, got '" + spec + "'");
}

Aoi ParseAoi(const std::string& text) {
  std::istringstream in(text);
  Aoi a;
  char c1 = 0, c2 = 0, c3 = 0;
  if (!(in >> a.x0 >> c1 >> a.y0 >> c2 >> a.width >> c3 >> a.height) || c1 != ',' || c2 != ',' ||
      c3 != ',' || !(in >> std::ws).eof() || a.x0 < 0 || a.y0 < 0 || a.width <= 0 ||
      a.height <= 0) {
    throw RoiError("an AOI is x0,y0,width,height in pixels, got '" + text + "'");
  }
  return a;
}

}  // namespace mlp::probe_fw
