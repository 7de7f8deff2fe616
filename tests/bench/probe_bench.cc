// Speed of the firmware on full reference-probe frames (2048 x 1536, 8 bit), one core, in one
// run with its baselines: a plain read of the same frames (the physical limit) and a naive
// OpenCV stripe finder (per-row maximum + centroid). Also triangulated points per second and the
// ROI extraction time per LED frame.
// Run: build/bin/mlp_probe_bench --benchmark_counters_tabular=true

#include "mlp/probe_fw/epipolar.h"
#include "mlp/probe_fw/roi.h"
#include "mlp/probe_fw/triangulate.h"
#include "mlp/sim/render.h"

#include <cmath>
#include <cstdint>

#include <benchmark/benchmark.h>
#include <opencv2/core.hpp>

namespace {

using namespace mlp;

const std::string kReference = std::string(MLP_SOURCE_DIR) + "/samples/probes/reference_probe.json";

// Full-sensor frames of a face with a 12 mm hole, 120 mm below the probe: 8 laser frames spread
// over the sweep and the LED frame, rendered once.
struct Frames {
  probe_fw::ProbeModel model;
  std::vector<probe_fw::Frame> laser;
  probe_fw::Frame led;
};

const Frames& Cached() {
  static const Frames frames = [] {
    sim::Scene s;
    s.workpiece =
        sim::MakeDifference(sim::MakeBox({-60, -60, -30}, {60, 60, 0}, 0.6),
                            {sim::MakeRevolution({0, 0, -31}, {0, 0, 1}, 32, 6.0, 6.0, 0.6)});
    sim::Capture c;
    c.mcs_from_flange.linear() =
        Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()).toRotationMatrix();
    c.mcs_from_flange.translation() = geometry::Vec3(0, 0, 120);
    s.captures.push_back(c);
    const sim::VirtualProbe probe(probe_fw::LoadProbeModel(kReference), s);
    sim::SweepOptions o;
    o.aoi = {0, 0, probe.model().camera.width_px, probe.model().camera.height_px};
    o.first_column = 100;
    o.last_column = 900;
    o.column_step = 100;
    auto r = probe.Render(c, o);
    return Frames{probe.model(), std::move(r.laser), std::move(r.led)};
  }();
  return frames;
}

void SetRates(benchmark::State& state, size_t pixels_per_frame) {
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["Mpixels_per_s"] =
      benchmark::Counter(1e-6 * static_cast<double>(state.iterations() * pixels_per_frame),
                         benchmark::Counter::kIsRate);
}

// The physical limit: touch every pixel of a frame once (a vectorised sum).
void BM_FrameRead(benchmark::State& state) {
  const auto& f = Cached();
  size_t k = 0;
  for (auto _ : state) {
    const auto& px = f.laser[k++ % f.laser.size()].pixels;
    std::uint64_t sum = 0;
    for (std::uint16_t v : px) sum += v;
    benchmark::DoNotOptimize(sum);
  }
  SetRates(state, f.laser[0].pixels.size());
}

// The laser frames transposed: the same stripes running along the rows (a probe turned by 90
// degrees), 1536 x 2048.
const std::vector<probe_fw::Frame>& Turned() {
  static const std::vector<probe_fw::Frame> turned = [] {
    std::vector<probe_fw::Frame> out;
    for (const probe_fw::Frame& f : Cached().laser) {
      probe_fw::Frame t = f;
      t.aoi = {f.aoi.y0, f.aoi.x0, f.aoi.height, f.aoi.width};
      for (int y = 0; y < f.aoi.height; ++y) {
        for (int x = 0; x < f.aoi.width; ++x)
          t.pixels[static_cast<size_t>(x) * f.aoi.height + y] = f.At(x, y);
      }
      out.push_back(std::move(t));
    }
    return out;
  }();
  return turned;
}

// Arg 0: rows only (the scan before stripes in any direction), 1: rows and columns (default),
// 2: rows and columns on the frames turned by 90 degrees (the column scan finds every centre),
// 3: rows and columns smoothed along the stripe.
void BM_StripeExtract(benchmark::State& state) {
  const std::vector<probe_fw::Frame>& frames = state.range(0) == 2 ? Turned() : Cached().laser;
  probe_fw::StripeOptions options;
  options.axes = state.range(0) == 0 ? probe_fw::StripeAxes::kRows : probe_fw::StripeAxes::kBoth;
  // As under speckle (PROBE.md): a Gaussian of 2 px along the stripe (a grain of 1 px).
  if (state.range(0) == 3) options.along_stripe_sigma_px = 2.0;
  probe_fw::StripeExtractor extractor(probe_fw::RowMask::Full(frames[0].aoi), options);
  std::vector<probe_fw::StripePoint> points;
  size_t k = 0, found = 0;
  for (auto _ : state) {
    points.clear();
    probe_fw::StripeCounts counts;
    extractor.Extract(frames[k++ % frames.size()], &points, &counts);
    found += points.size();
  }
  SetRates(state, frames[0].pixels.size());
  state.counters["points_per_frame"] =
      static_cast<double>(found) / static_cast<double>(state.iterations());
}

// The stripe step with one direct candidate per epipolar line (issue 50): the row and column
// scans with their rejected candidates kept as evidence, then the traces, conflicts and the fit
// along each trace (speckle-free frames: no smoothing along the stripe).
void BM_StripeEpipolar(benchmark::State& state) {
  const auto& f = Cached();
  probe_fw::StripeExtractor extractor(probe_fw::RowMask::Full(f.laser[0].aoi), {});
  std::vector<probe_fw::StripePoint> points, rejected;
  size_t k = 0, kept = 0;
  for (auto _ : state) {
    points.clear(), rejected.clear();
    probe_fw::StripeCounts counts;
    extractor.Extract(f.laser[k++ % f.laser.size()], &points, &counts, &rejected);
    probe_fw::EpipolarCounts held;
    probe_fw::KeepOneDirectPerEpipolarLine(f.model, rejected, {}, &points, &held);
    kept += points.size();
  }
  SetRates(state, f.laser[0].pixels.size());
  state.counters["points_per_frame"] =
      static_cast<double>(kept) / static_cast<double>(state.iterations());
}

// Naive baseline: per row, OpenCV's maximum, then the centre of mass of +-3 px around it.
void BM_NaiveOpenCvStripe(benchmark::State& state) {
  const auto& f = Cached();
  std::vector<cv::Mat> mats;
  for (const auto& l : f.laser) {
    mats.emplace_back(l.aoi.height, l.aoi.width, CV_16UC1,
                      const_cast<std::uint16_t*>(l.pixels.data()));
  }
  size_t k = 0;
  for (auto _ : state) {
    const cv::Mat& m = mats[k++ % mats.size()];
    double acc = 0.0;
    for (int y = 0; y < m.rows; ++y) {
      double max_value = 0;
      cv::Point at;
      cv::minMaxLoc(m.row(y), nullptr, &max_value, nullptr, &at);
      double mass = 0, moment = 0;
      for (int x = std::max(0, at.x - 3); x <= std::min(m.cols - 1, at.x + 3); ++x) {
        mass += m.at<std::uint16_t>(y, x),
            moment += x * static_cast<double>(m.at<std::uint16_t>(y, x));
      }
      acc += mass > 0 ? moment / mass : 0.0;
    }
    benchmark::DoNotOptimize(acc);
  }
  SetRates(state, f.laser[0].pixels.size());
}

void BM_Triangulate(benchmark::State& state) {
  const auto& f = Cached();
  std::vector<probe_fw::StripePoint> points;
  probe_fw::StripeCounts counts;
  probe_fw::ExtractStripe(f.laser[3], probe_fw::RowMask::Full(f.laser[3].aoi), {}, &points,
                          &counts);
  size_t k = 0;
  for (auto _ : state) {
    const auto& p = points[k++ % points.size()];
    benchmark::DoNotOptimize(
        probe_fw::Triangulate(f.model, p.x_px, p.y_px, f.laser[3].laser_column).value());
  }
  state.counters["points_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_RoiHoleOnLedFrame(benchmark::State& state) {
  const auto& f = Cached();
  const double cx = f.model.camera.cx_px, cy = f.model.camera.cy_px;
  for (auto _ : state) benchmark::DoNotOptimize(probe_fw::FindHole(f.led, {cx, cy}, 20, 800));
}

void BM_RoiFaceOnLedFrame(benchmark::State& state) {
  const auto& f = Cached();
  for (auto _ : state) benchmark::DoNotOptimize(probe_fw::FaceMask(f.led, {100, 100}, 6));
}

// Issue 16's physics: a 300 x 200 px sweep of 24 frames (columns 2 apart) of the face beside a
// wall, 120 mm away. Arg 0: matt everything, independent speckle (the physics before issue 16);
// 1: the same with the lens's speckle grain (f/4.7, contrast 0.3, the coherent imager); 2: the
// wall and the floor ground steel, one specular inter-reflection (traced once per sweep).
struct Sweep {
  probe_fw::ProbeModel model;
  sim::Scene scene;
  sim::SweepOptions options;
};

Sweep PhysicsSweep(int physics) {
  Sweep s;
  s.model = probe_fw::LoadProbeModel(kReference);
  if (physics == 1) s.model.camera.f_number = 4.7, s.model.noise.speckle_contrast = 0.3;
  const sim::Gloss gloss = physics == 2 ? sim::Gloss{0.55, 0.12} : sim::Gloss{};
  s.scene.workpiece =
      sim::MakeFinish(sim::MakeUnion({sim::MakeBox({-60, -60, -30}, {60, 60, 0}, 0.6),
                                      sim::MakeBox({-60, -60, 0}, {-4, 60, 30}, 0.6)}),
                      gloss, physics == 2 ? 0.08 : -1.0);
  sim::Capture c;
  c.mcs_from_flange.linear() = Eigen::AngleAxisd(M_PI, geometry::Vec3::UnitX()).toRotationMatrix();
  c.mcs_from_flange.translation() = geometry::Vec3(0.3, -0.2, 120);
  s.scene.captures.push_back(c);
  s.options.aoi = {880, 668, 300, 200};
  s.options.first_column = 440;
  s.options.last_column = 486;
  s.options.column_step = 2;
  // Seen from straight above, the ground face sends half a white face's light (its lobe, 13 deg
  // off the mirror direction): exposure 1.5 keeps the stripe below full scale.
  s.options.exposure = physics == 2 ? 1.5 : 1.0;
  return s;
}

void BM_RenderSweep(benchmark::State& state) {
  const Sweep s = PhysicsSweep(static_cast<int>(state.range(0)));
  const sim::VirtualProbe probe(s.model, s.scene);
  size_t frames = 0;
  for (auto _ : state) {
    const auto r = probe.Render(s.scene.captures[0], s.options);
    frames += r.laser.size();
  }
  state.counters["frames"] = static_cast<double>(frames) / static_cast<double>(state.iterations());
}

void BM_FirmwareSweep(benchmark::State& state) {
  const Sweep s = PhysicsSweep(static_cast<int>(state.range(0)));
  const sim::VirtualProbe probe(s.model, s.scene);
  const auto r = probe.Render(s.scene.captures[0], s.options);
  size_t points = 0;
  for (auto _ : state) {
    probe_fw::StripeCounts counts;
    points += probe_fw::ReconstructSweep(s.model, r.laser, probe_fw::RowMask::Full(s.options.aoi),
                                         {}, &counts)
                  .size();
  }
  state.counters["frames"] = static_cast<double>(r.laser.size());
  state.counters["points_per_frame"] =
      static_cast<double>(points) / static_cast<double>(state.iterations() * r.laser.size());
}

BENCHMARK(BM_FrameRead)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderSweep)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FirmwareSweep)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StripeExtract)->Arg(0)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_StripeEpipolar)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_NaiveOpenCvStripe)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Triangulate)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_RoiHoleOnLedFrame)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RoiFaceOnLedFrame)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
