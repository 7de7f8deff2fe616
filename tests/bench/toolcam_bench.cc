// The tool camera's costs (issue 7): rendering one virtual shadow image, and measuring a tool
// from a strobe plan's images (outline, indexing, per-flute fits), against a baseline in the
// same run: one read of every pixel of those images. 1024 x 768 px images, the worn D10 sample,
// 5000 rpm, 50 images at 7.2 deg.
// Run: build/bin/mlp_toolcam_bench --benchmark_counters_tabular=true

#include "mlp/toolcam/measure.h"

#include <numeric>

#include <benchmark/benchmark.h>

namespace {

using namespace mlp::toolcam;
const std::string kTools = std::string(MLP_SOURCE_DIR) + "/samples/tools/";

struct Sequence {
  StrobePlan plan;
  std::vector<std::vector<std::uint8_t>> frames;
};

const Sequence& Worn() {
  static const Sequence s = [] {
    Sequence q;
    StrobeRequest r;
    r.rpm = 5000, r.frame_rate_hz = 50, r.resolution_deg = 7.2, r.pulse_share = 0.1;
    q.plan = PlanStrobe(r);
    const ToolDescription tool = LoadTool(kTools + "endmill_d10_z4_worn.json");
    std::mt19937 rng(1);
    for (int pos : q.plan.position)
      q.frames.push_back(RenderToolFrame(tool, ToolCameraModel(),
                                         0.3 + 2 * M_PI * pos / q.plan.positions, 0.001, rng)
                             .pixels);
    return q;
  }();
  return s;
}

void BM_PixelReadBaseline(benchmark::State& state) {
  const Sequence& s = Worn();
  for (auto _ : state) {
    long sum = 0;
    for (const auto& f : s.frames) sum += std::accumulate(f.begin(), f.end(), 0L);
    benchmark::DoNotOptimize(sum);
  }
  state.counters["images"] = static_cast<double>(s.frames.size());
}

void BM_RenderOneImage(benchmark::State& state) {
  const ToolDescription tool = LoadTool(kTools + "endmill_d10_z4_worn.json");
  std::mt19937 rng(2);
  for (auto _ : state)
    benchmark::DoNotOptimize(RenderToolFrame(tool, ToolCameraModel(), 0.3, 0.001, rng));
}

void BM_MeasureTool(benchmark::State& state) {
  const Sequence& s = Worn();
  const ToolDescription nominal = LoadTool(kTools + "endmill_d10_z4_new.json");
  MeasureOptions o;
  o.blur_rad = s.plan.pulse_width_us * 1e-6 * s.plan.rpm / 60 * 2 * M_PI;
  for (auto _ : state)
    benchmark::DoNotOptimize(
        MeasureTool(s.frames, s.plan.position, s.plan.positions, nominal, ToolCameraModel(), o));
  state.counters["images"] = static_cast<double>(s.frames.size());
}

}  // namespace

BENCHMARK(BM_PixelReadBaseline)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RenderOneImage)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MeasureTool)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
