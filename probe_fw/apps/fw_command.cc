#include "fw_command.h"

#include "mlp/base/input_error.h"
#include "mlp/probe_fw/cloud_io.h"
#include "mlp/probe_fw/frame_source.h"
#include "mlp/probe_fw/probe_model.h"
#include "mlp/probe_fw/roi_spec.h"
#include "mlp/probe_fw/stripe.h"
#include "mlp/probe_fw/stripe_file.h"
#include "mlp/probe_fw/sweep.h"
#include "mlp/probe_fw/triangulate.h"

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <memory>
#include <optional>

#include "board.h"
#include "cli.h"
#include <nlohmann/json.hpp>
#include <unistd.h>

namespace mlp::probe_fw {
namespace {

using cli::UsageError;

constexpr const char* kUsage =
    "usage: mlp-fw run --probe PROBE_FILE --frames DIR --roi ROI_SPEC --out CLOUD.ply [--json]\n"
    "       mlp-fw run --probe PROBE_FILE --camera /dev/videoN --aoi X0,Y0,W,H\n"
    "                  --columns FIRST:LAST:STEP [--exposure-us US] [BOARD OPTIONS]\n"
    "                  --roi ROI_SPEC --out CLOUD.ply [--json]\n"
    "       mlp-fw stripes --frames DIR --out STRIPES.json [--roi ROI_SPEC] [--json]\n"
    "       mlp-fw serve --probe PROBE_FILE --port N --key KEY_FILE [--host ADDRESS]\n"
    "                    (--camera /dev/videoN | --frames-from DIR) [--projector board|virtual]\n"
    "                    [--buffer CLOUDS] [--captures N] [BOARD OPTIONS]\n"
    "  serve     the probe's main loop: connects to the host's probe link and answers capture\n"
    "            requests until SIGINT/SIGTERM (or N captures acknowledged); --frames-from\n"
    "            answers from a recorded capture (lit by the virtual projector by default)\n"
    "  BOARD OPTIONS  --spi DEV --gpio-chip DEV --laser-line N --led-line N (the projector's\n"
    "            drivers); serve also --battery DIR --thermal FILE (sysfs readings for the "
    "status)\n"
    "  ROI_SPEC  full | rect:X0,Y0,W,H | hole:X,Y | edge:X,Y | face:X,Y (sensor pixels; hole,\n"
    "            edge and face are found on the LED frame from the hint X,Y: docs/CLI.md)\n"
    "  stripes   calibration mode: the stripe centres with the projector column lit, not\n"
    "            triangulated (needs no probe model; default ROI full)\n"
    "  --json    print the summary as JSON\n"
    "exit codes: 0 cloud written (serve: stopped), 2 bad arguments or input, 3 camera or\n"
    "            projector missing or failed, 1 bug\n";

std::vector<double> ParseColumns(const std::string& text) {
  double first = 0, last = 0, step = 0;
  char c1 = 0, c2 = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf", &first, &c1, &last, &c2, &step) != 5 ||
      c1 != ':' || c2 != ':' || !(step > 0.0) || last < first || (last - first) / step > 100000) {
    throw UsageError("--columns is FIRST:LAST:STEP with STEP > 0, got '" + text + "'");
  }
  // first + i * step, as the agent plans a sweep and the virtual probe renders one.
  std::vector<double> columns;
  const auto steps = static_cast<size_t>((last - first) / step + 1e-9);
  for (size_t i = 0; i <= steps; ++i) columns.push_back(first + static_cast<double>(i) * step);
  return columns;
}

// The board's camera and projector: the sweep as the agent takes it (sweep.h), replayed as a
// source of frames.
std::unique_ptr<FrameSource> SweepWithCamera(const base::Args& o, const ProbeModel& probe) {
  SweepPlan plan;
  plan.aoi = cli::ParseAoi(o.Text("--aoi"));
  plan.exposure_us = o.Number("--exposure-us", 100.0);
  plan.columns = ParseColumns(o.Text("--columns"));
  // The camera first: it is the device the command line names, the projector's have defaults.
  const auto camera = OpenV4l2Camera(o.Text("--camera"), plan, probe.camera.bit_depth);
  const auto projector = OpenBoardProjector(o, probe);
  return MakeFrameList(TakeSweep(*projector, *camera, plan),
                       {probe.serial, probe.calibration_id, "camera"});
}

std::unique_ptr<FrameSource> OpenSource(const base::Args& o, const ProbeModel& probe) {
  if (o.Has("--frames") == o.Has("--camera")) throw UsageError("give either --frames or --camera");
  if (o.Has("--frames")) return OpenDirectorySource(o.Text("--frames"));
  return SweepWithCamera(o, probe);
}

struct Summary {
  size_t frames = 0, laser_frames = 0, points = 0, roi_pixels = 0;
  std::optional<base::EdgeSight> edge;  ///< the LED frame's edge of an edge ROI
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
                                  {"too_wide", s.counts.too_wide},
                                  {"too_narrow", s.counts.too_narrow},
                                  {"cut", s.counts.cut},
                                  {"indirect", s.counts.indirect},
                                  {"reflectance_slope", s.counts.reflectance_dropped},
                                  {"second_on_epipolar_line", s.counts.second_on_line},
                                  {"undecided_on_epipolar_line", s.counts.undecided_on_line},
                                  {"beside_rejected_stripe", s.counts.beside_rejected},
                                  {"isolated", s.counts.isolated}}},
                                {"probe_serial", meta.probe_serial},
                                {"capture_id", meta.capture_id},
                                {"seconds", s.seconds}};
    if (s.edge) j["edge"] = {{"points", s.edge->points}, {"rms_px", s.edge->rms_px}};
    out << j.dump(2) << "\n";
    return;
  }
  out << "mlp-fw: " << s.points << (output == "cloud" ? " points" : " stripe points") << " from "
      << s.laser_frames << " laser frames (" << s.roi_pixels << " ROI pixels each) -> " << path
      << "\n"
      << "  rejected stripes: " << s.counts.weak << " weak, " << s.counts.saturated
      << " saturated, " << s.counts.double_peak << " double-peaked, " << s.counts.too_wide
      << " too wide, " << s.counts.too_narrow << " too narrow, " << s.counts.cut
      << " cut by the ROI, " << s.counts.indirect << " indirect light (reflections), "
      << s.counts.reflectance_dropped << " reflectance changing too fast, "
      << s.counts.second_on_line << " weaker second on an epipolar line, "
      << s.counts.undecided_on_line << " undecided on one, " << s.counts.beside_rejected
      << " beside a brighter rejected stripe, " << s.counts.isolated
      << " on a trace of a few lines\n";
  if (s.edge)
    out << "  edge on the LED frame: " << s.edge->points << " points, " << s.edge->rms_px
        << " px rms about its line\n";
  out << "  probe " << meta.probe_serial << ", capture " << meta.capture_id << ", " << s.seconds
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
  const base::Args o(
      args, {{"--probe", "--frames", "--camera", "--aoi", "--columns", "--exposure-us", "--roi",
              "--out", "--spi", "--gpio-chip", "--laser-line", "--led-line"},
             {"--json"}});
  const auto start = std::chrono::steady_clock::now();
  const ProbeModel probe = LoadProbeModel(o.Text("--probe"));
  const std::string roi = o.Text("--roi"), path = o.Text("--out");
  auto source = OpenSource(o, probe);
  const CaptureMeta meta = source->Meta();
  if (meta.probe_serial != probe.serial) {
    throw UsageError("the frames are from probe " + meta.probe_serial + ", the model is for " +
                     probe.serial);
  }
  Summary s;
  const CaptureFrames frames = ReadAll(*source, &s, err);
  const RoiFound found = LocateRoi(roi, frames.laser[0].aoi, frames.led ? &*frames.led : nullptr);
  const RowMask& mask = found.mask;
  const auto cloud = ReconstructSweep(probe, frames.laser, mask, StripeOptions{}, &s.counts);
  if (found.edge) s.edge = SightOfEdge(probe.camera, *found.edge);
  WriteCloudPly(path, cloud, meta, s.edge);
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
  const base::Args o(args, {{"--frames", "--roi", "--out"}, {"--json"}});
  const auto start = std::chrono::steady_clock::now();
  const std::string path = o.Text("--out");
  const auto source = OpenDirectorySource(o.Text("--frames"));
  const CaptureMeta meta = source->Meta();
  Summary s;
  const CaptureFrames frames = ReadAll(*source, &s, err);
  const RowMask mask =
      ParseRoi(o.Text("--roi", "full"), frames.laser[0].aoi, frames.led ? &*frames.led : nullptr);
  StripeFile file{meta.probe_serial, meta.capture_id, {}};
  std::vector<StripePoint> found;
  StripeExtractor extractor(mask, StripeOptions{});
  for (const Frame& l : frames.laser) {
    found.clear();
    extractor.Extract(l, &found, &s.counts);
    for (const StripePoint& p : found)
      file.points.push_back({p.x_px, p.y_px, l.laser_column, p.quality});
  }
  SaveStripeFile(file, path);
  s.laser_frames = frames.laser.size();
  s.points = file.points.size();
  s.roi_pixels = mask.PixelCount();
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Print(s, meta, "stripes", path, o.Has("--json"), out);
  return cli::kExitOk;
}

std::atomic<bool> g_stop{false};
extern "C" void OnSignal(int) { g_stop = true; }

// A recorded capture as the camera's view: requests must ask for its window and its columns.
Camera RecordedView(const std::string& dir, const ProbeModel& probe, const Projector& projector) {
  std::vector<Frame> frames;
  const auto source = OpenDirectorySource(dir);
  if (source->Meta().probe_serial != probe.serial) {
    throw UsageError("the frames in " + dir + " are from probe " + source->Meta().probe_serial +
                     ", the model is for " + probe.serial);
  }
  Frame f;
  while (source->Next(&f)) frames.push_back(std::move(f));
  if (frames.empty()) throw UsageError(dir + " holds no frame");
  return [frames, &projector](const link::CaptureRequest&, const SweepPlan& plan) {
    const Aoi& a = frames.back().aoi;
    if (plan.aoi.x0 != a.x0 || plan.aoi.y0 != a.y0 || plan.aoi.width != a.width ||
        plan.aoi.height != a.height) {
      throw RequestError("the recorded capture's window is " + std::to_string(a.width) + " x " +
                         std::to_string(a.height) + " at " + std::to_string(a.x0) + "," +
                         std::to_string(a.y0) + "; the request asks for another");
    }
    return MakeRecordedCamera(frames, projector);
  };
}

int RunServe(const std::vector<std::string>& args, std::ostream& out) {
  const base::Args o(args, {{"--probe", "--host", "--port", "--key", "--camera", "--frames-from",
                             "--projector", "--buffer", "--captures", "--spi", "--gpio-chip",
                             "--laser-line", "--led-line", "--battery", "--thermal"},
                            {}});
  const ProbeModel probe = LoadProbeModel(o.Text("--probe"));
  if (o.Has("--frames-from") == o.Has("--camera")) {
    throw UsageError("give either --camera or --frames-from");
  }
  const double port = o.Number("--port", 0.0);
  if (!(port >= 1.0 && port <= 65535.0)) throw UsageError("--port must be 1..65535");
  const double buffer = o.Number("--buffer", 64), captures = o.Number("--captures", 0);
  if (!(buffer >= 1 && buffer <= 4096)) throw UsageError("--buffer must be 1..4096 clouds");
  if (!(captures >= 0 && captures <= 1e9)) throw UsageError("--captures must be 0..1e9");
  ServeOptions options;
  options.link.host = o.Text("--host", "127.0.0.1");
  options.link.port = static_cast<std::uint16_t>(port);
  options.link.serial = probe.serial;
  options.link.key = link::LoadKeyFile(o.Text("--key"));
  options.link.buffer_clouds = static_cast<std::size_t>(buffer);
  options.max_captures = static_cast<std::uint64_t>(captures);
  link::Log log = [&out](const std::string& line) {
    out << "mlp-fw: " << line << "\n" << std::flush;
  };
  options.board = BoardReadings(o, log);
  const std::string kind = o.Text("--projector", o.Has("--camera") ? "board" : "virtual");
  if (kind != "board" && kind != "virtual") throw UsageError("--projector is board or virtual");
  // A camera missing at start is a device fault (exit 3, a service manager retries), not a
  // failure of every request that comes.
  if (o.Has("--camera")) CheckV4l2Camera(o.Text("--camera"));
  const std::unique_ptr<Projector> projector =
      kind == "board" ? OpenBoardProjector(o, probe)
                      : std::make_unique<VirtualProjector>(probe.projector.columns - 1.0);
  Camera camera;
  if (o.Has("--camera")) {
    camera = [device = o.Text("--camera"), depth = probe.camera.bit_depth](
                 const link::CaptureRequest&, const SweepPlan& plan) {
      return OpenV4l2Camera(device, plan, depth);
    };
  } else {
    camera = RecordedView(o.Text("--frames-from"), probe, *projector);
  }
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  out << "mlp-fw: probe " << probe.serial << " (" << kind << " projector) serving "
      << options.link.host << ":" << options.link.port << "\n"
      << std::flush;
  ServeProbe(probe, std::move(camera), projector.get(), options, g_stop, log);
  return cli::kExitOk;
}

}  // namespace

int RunFwCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  if (args.empty() || (args[0] != "run" && args[0] != "stripes" && args[0] != "serve")) {
    (args.empty() || args[0] == "--help" ? out : err) << kUsage;
    return !args.empty() && args[0] == "--help" ? cli::kExitOk : cli::kExitBadInput;
  }
  try {
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (args[0] == "serve") return RunServe(rest, out);
    return args[0] == "run" ? Run(rest, out, err) : Stripes(rest, out, err);
  } catch (const UsageError& e) {
    err << "mlp-fw: " << e.what() << "\n" << kUsage;
    return cli::kExitBadInput;
  } catch (const RoiError& e) {
    err << "mlp-fw: " << e.what() << "\n";
    return cli::kExitBadInput;
  } catch (const ProjectorError& e) {
    err << "mlp-fw: " << e.what() << "\n";
    return cli::kExitNoDevice;
  } catch (const link::LinkError& e) {  // the key file: missing, unreadable, others may read it
    err << "mlp-fw: " << e.what() << "\n";
    return cli::kExitBadInput;
  } catch (const FrameIoError& e) {
    err << "mlp-fw: " << e.what() << "\n";
    return std::string(e.what()).rfind("camera", 0) == 0 ? cli::kExitNoDevice : cli::kExitBadInput;
  } catch (const base::InputError& e) {  // the probe model, a stripe or cloud file
    err << "mlp-fw: " << e.what() << "\n";
    return cli::kExitBadInput;
  } catch (const std::exception& e) {
    err << "mlp-fw: internal error: " << e.what() << "\n";
    return cli::kExitFailure;
  }
}

}  // namespace mlp::probe_fw
