// The tool setter's streaming processor (issue 8): samples a second on one core, against a
// baseline in the same run: one read of every sample of the same signal (a sum). The signal:
// the seed's two-tooth D6 at 1500 rpm, 6 mm/min, 80 kHz, 10 drops a second, 1.2 s (96,000
// samples) through the trigger and on.
// Run: build/bin/mlp_setter_bench --benchmark_counters_tabular=true

#include "mlp/setter/beam_processor.h"
#include "mlp/setter/beam_signal.h"

#include <numeric>

#include <benchmark/benchmark.h>

namespace {

using namespace mlp::setter;

struct Fixture {
  CalibrationCurve curve;
  BeamSignal signal;
};

const Fixture& Signal() {
  static const Fixture f = [] {
    Fixture x;
    ToolInBeam pin;
    pin.tooth_radius_mm = {3.0};
    Motion m;
    m.gap_mm = 0.15, m.duration_s = 2.5;
    const BeamSignal p = GenerateSignal(BeamModel(), pin, m, 1);
    x.curve = CalibrateFromPin(p.volts, p.sample_rate_hz, 6.0, true);
    BeamModel beam;
    beam.drops_per_s = 10;
    ToolInBeam tool;
    tool.rpm = 1500, tool.tooth_radius_mm = {3.0, 3.01};
    m.gap_mm = 0.06, m.duration_s = 1.2;
    x.signal = GenerateSignal(beam, tool, m, 2);
    return x;
  }();
  return f;
}

void BM_SampleReadBaseline(benchmark::State& state) {
  const auto& v = Signal().signal.volts;
  for (auto _ : state) benchmark::DoNotOptimize(std::accumulate(v.begin(), v.end(), 0.0f));
  state.SetItemsProcessed(state.iterations() * static_cast<long>(v.size()));
}
BENCHMARK(BM_SampleReadBaseline)->Unit(benchmark::kMicrosecond);

void BM_ProcessSignal(benchmark::State& state) {
  const Fixture& f = Signal();
  ProcessorConfig c;
  c.rpm = 1500, c.teeth = 2, c.feed_mm_min = 6, c.curve = f.curve;
  for (auto _ : state) {
    BeamProcessor p(c);
    for (float v : f.signal.volts) p.Push(v);
    benchmark::DoNotOptimize(p.trigger().sample);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long>(f.signal.volts.size()));
}
BENCHMARK(BM_ProcessSignal)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
