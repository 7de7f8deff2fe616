#include "mlp/probe_fw/fw_command.h"

#include "mlp/probe_fw/cli.h"
#include "mlp/probe_fw/cloud_io.h"
#include "mlp/probe_fw/frame_source.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/roi.h"
#include "mlp/probe_fw/stripe.h"
#include "mlp/probe_fw/stripe_file.h"
#include "mlp/probe_fw/triangulate.h"

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>
#include <unistd.h>

namespace mlp::probe_fw {
namespace {

using cli::UsageError;

constexpr const char* kUsage =
    "usage: mlp-fw run --probe PROBE_FILE --frames DIR --roi ROI_SPEC --out CLOUD.ply [--json]\n"
    "       mlp-fw run --probe PROBE_FILE --camera /dev/videoN --aoi X0,Y0,W,H\n"
    "                  --columns FIRST:LAST:STEP --roi ROI_SPEC --out CLOUD.ply [--json]\n"
    "       mlp-fw stripes --frames DIR --out STRIPES.json [--roi ROI_SPEC] [--json]\n"
    "  ROI_SPEC  full | rect:X0,Y0,W,H | hole:X,Y | edge:X,Y | face:X,Y (sensor pixels; hole,\n"
    "            edge and face are found on the LED frame from the hint X,Y: docs/CLI.md)\n"
    "  stripes   calibration mode: the stripe centres with the projector column lit, not\n"
    "            triangulated (needs no probe model; default ROI full)\n"
    "  --json    print the summary as JSON\n"
    "exit codes: 0 cloud written, 2 bad arguments or input, 3 camera missing or failed, 1 bug\n";

std::vector<double> ParseColumns(const std::string& text) {
  double first = 0, last = 0, step = 0;
  char c1 = 0, c2 = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf", &first, &c1, &last, &c2, &step) != 5 ||
      c1 != ':' || c2 != ':' || !(step > 0.0) || last < first || (last - first) / step > 100000) {
    throw UsageError("--columns is FIRST:LAST:STEP with STEP > 0, got '" + text + "'");
  }
  std::vector<double> columns{-1.0};  // the LED frame comes first
  for (double c = first; c <= last + 1e-9; c += step) columns.push_back(c);
  return columns;
}

std::unique_ptr<FrameSource> OpenSource(const cli::Options& o, const ProbeModel& probe) {
  if (o.Has("--frames") == o.Has("--camera")) throw UsageError("give either --frames or --camera");
  if (o.Has("--frames")) return OpenDirectorySource(o.Required("--frames"));
  return OpenV4l2Source(o.Required("--camera"), cli::ParseAoi(o.Required("--aoi")),
                        probe.camera.bit_depth, ParseColumns(o.Required("--columns")),
                        {probe.serial, probe.calibration_id, "camera"});
}

struct Summary {
  size_t frames = 0, laser_frames = 0, points = 0, roi_pixels = 0;
  StripeCounts counts;
  double seconds = 0.0;
};

// `output` names what was written: "cloud" (points) or "stripes" (stripe observations).
void Print(const Summary& s,
           const CaptureMeta& meta,
           const std::string& output,
           const std::string& path,
           bool as_json,
           std::ostream& out) {
  if (as_json) {
    nlohmann::ordered_json j = {{output, path},
                                {"points", s.points},
                                {"frames", s.frames},
                                {"laser_frames", s.laser_frames},
                                {"roi_pixels", s.roi_pixels},
                                {"rejected",
                                 {{"weak", s.counts.weak},
                                  {"saturated", s.counts.saturated},
                                  {"double_peak", s.counts.double_peak},
                                  {"too_wide", s.counts.too_wide}}},
                                {"probe_serial", meta.probe_serial},
                                {"capture_id", meta.capture_id},
                                {"seconds", s.seconds}};
    out << j.dump(2) << "\n";
    return;
  }
  out << "mlp-fw: " << s.points << (output == "cloud" ? " points" : " stripe points") << " from "
      << s.laser_frames << " laser frames (" << s.roi_pixels << " ROI pixels each) -> " << path
      << "\n"
      << "  rejected stripes: " << s.counts.weak << " weak, " << s.counts.saturated
      << " saturated, " << s.counts.double_peak << " double-peaked, " << s.counts.too_wide
      << " too wide\n"
      << "  probe " << meta.probe_serial << ", capture " << meta.capture_id << ", " << s.seconds
      << " s\n";
}

struct CaptureFrames {
  std::optional<Frame> led;
  std::vector<Frame> laser;
};

// Every frame of the capture; refuses a capture without laser frames or with laser frames of
// different AOIs (one ROI mask serves them all).
CaptureFrames ReadAll(FrameSource& source, Summary* s, std::ostream& err) {
  CaptureFrames c;
  const bool progress = isatty(STDERR_FILENO) != 0;  // a log file gets no carriage returns
  Frame f;
  while (source.Next(&f)) {
    ++s->frames;
    if (f.IsLaser())
      c.laser.push_back(std::move(f));
    else
      c.led = std::move(f);
    if (progress && s->frames % 50 == 0)
      err << "mlp-fw: " << s->frames << " frames read\r" << std::flush;
  }
  if (c.laser.empty()) throw UsageError("the capture holds no laser frame");
  for (const Frame& l : c.laser) {
    if (l.aoi.x0 != c.laser[0].aoi.x0 || l.aoi.y0 != c.laser[0].aoi.y0 ||
        l.aoi.width != c.laser[0].aoi.width || l.aoi.height != c.laser[0].aoi.height) {
      throw UsageError("the laser frames of one capture must share one AOI");
    }
  }
  return c;
}

int Run(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const cli::Options o(args,
                       {"--probe", "--frames", "--camera", "--aoi", "--columns", "--roi", "--out"},
                       {"--json"});
  const auto start = std::chrono::steady_clock::now();
  const ProbeModel probe = LoadProbeModel(o.Required("--probe"));
  const std::string roi = o.Required("--roi"), path = o.Required("--out");
  auto source = OpenSource(o, probe);
  const CaptureMeta meta = source->Meta();
  if (meta.probe_serial != probe.serial) {
    throw UsageError("the frames are from probe " + meta.probe_serial + ", the model is for " +
                     probe.serial);
  }
  Summary s;
  const CaptureFrames frames = ReadAll(*source, &s, err);
  const RowMask mask = ParseRoi(roi, frames.laser[0].aoi, frames.led ? &*frames.led : nullptr);
  const auto cloud = ReconstructSweep(probe, frames.laser, mask, StripeOptions{}, &s.counts);
  WriteCloudPly(path, cloud, meta);
  s.laser_frames = frames.laser.size();
  s.points = cloud.size();
  s.roi_pixels = mask.PixelCount();
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Print(s, meta, "cloud", path, o.Has("--json"), out);
  return cli::kExitOk;
}

// Calibration mode: stripe centres with their projector column, no triangulation (the projector
// is what is being calibrated).
int Stripes(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  const cli::Options o(args, {"--frames", "--roi", "--out"}, {"--json"});
  const auto start = std::chrono::steady_clock::now();
  const std::string path = o.Required("--out");
  const auto source = OpenDirectorySource(o.Required("--frames"));
  const CaptureMeta meta = source->Meta();
  Summary s;
  const CaptureFrames frames = ReadAll(*source, &s, err);
  const RowMask mask =
      ParseRoi(o.Get("--roi", "full"), frames.laser[0].aoi, frames.led ? &*frames.led : nullptr);
  StripeFile file{meta.probe_serial, meta.capture_id, {}};
  std::vector<StripePoint> found;
  for (const Frame& l : frames.laser) {
    found.clear();
    ExtractStripe(l, mask, StripeOptions{}, &found, &s.counts);
    for (const StripePoint& p : found)
      file.points.push_back({p.x_px, p.y_px, l.laser_column, p.quality});
  }
  try {
    SaveStripeFile(file, path);
  } catch (const StripeFileError& e) {
    throw UsageError(e.what());
  }
  s.laser_frames = frames.laser.size();
  s.points = file.points.size();
  s.roi_pixels = mask.PixelCount();
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Print(s, meta, "stripes", path, o.Has("--json"), out);
  return cli::kExitOk;
}

// "X,Y" in sensor pixels.
Vec2 ParseHint(const std::string& text, const std::string& spec) {
  double x = 0, y = 0;
  char comma = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c", &x, &comma, &y, &extra) != 3 || comma != ',') {
    throw UsageError("the hint of " + spec + " is X,Y in sensor pixels");
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
  if (spec == "full") return RowMask::Full(aoi);
  const bool hole = spec.rfind("hole:", 0) == 0, face = spec.rfind("face:", 0) == 0;
  const bool edge = spec.rfind("edge:", 0) == 0;
  if (hole || face || edge) {
    if (led == nullptr) throw UsageError(spec + " needs the LED frame, and the capture has none");
    if (led->aoi.x0 != aoi.x0 || led->aoi.y0 != aoi.y0 || led->aoi.width != aoi.width ||
        led->aoi.height != aoi.height) {
      throw UsageError("the LED frame's AOI differs from the laser frames'");
    }
    const Vec2 hint = ParseHint(spec.substr(5), spec);
    RowMask m;
    if (hole) {
      const auto found = FindHole(*led, hint, 10.0, 2.0 * std::max(aoi.width, aoi.height));
      if (!found) throw UsageError("no hole around " + spec.substr(5) + " in the LED frame");
      m = AnnulusMask(aoi, found->center_px, kHoleInner * found->radius_px,
                      found->radius_px + kHoleOuterPx);
    } else if (edge) {
      const auto found = FindLineEdge(*led, hint, kEdgeSearchPx);
      if (!found) throw UsageError("no straight edge near " + spec.substr(5) + " in the LED frame");
      m = BandMask(aoi, found->point_px, found->direction, kEdgeBandPx);
    } else {
      m = FaceMask(*led, hint, kFaceErodePx);
    }
    if (m.PixelCount() == 0) throw UsageError("the ROI " + spec + " holds no pixel of the AOI");
    return m;
  }
  if (spec.rfind("rect:", 0) == 0) {
    const Aoi r = cli::ParseAoi(spec.substr(5));
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
    if (pixels == 0) throw UsageError("the ROI " + spec + " does not overlap the frames' AOI");
    return m;
  }
  throw UsageError("ROI_SPEC is full or rect:X0,Y0,W,H, got '" + spec + "'");
}

int RunFwCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || (args[0] != "run" && args[0] != "stripes")) {
    (args.empty() || args[0] == "--help" ? out : err) << kUsage;
    return !args.empty() && args[0] == "--help" ? cli::kExitOk : cli::kExitBadInput;
  }
  try {
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    return args[0] == "run" ? Run(rest, out, err) : Stripes(rest, out, err);
  } catch (const UsageError& e) {
    err << "mlp-fw: " << e.what() << "\n" << kUsage;
    return cli::kExitBadInput;
  } catch (const ProbeModelError& e) {
    err << "mlp-fw: " << e.what() << "\n";
    return cli::kExitBadInput;
  } catch (const FrameIoError& e) {
    err << "mlp-fw: " << e.what() << "\n";
    return std::string(e.what()).rfind("camera", 0) == 0 ? cli::kExitNoDevice : cli::kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp-fw: internal error: " << e.what() << "\n";
    return cli::kExitFailure;
  }
}

}  // namespace mlp::probe_fw
