// The probe link's full path on loopback: encode -> authenticate -> send -> verify -> decode ->
// acknowledge, in clouds and points per second, against the codec alone and a plain copy of the
// same coordinates in the same run. Run: build/bin/mlp_link_bench --benchmark_counters_tabular=true

#include "mlp/link/transport.h"

#include <atomic>
#include <cstdio>
#include <cstring>
#include <random>
#include <utility>

#include <benchmark/benchmark.h>

namespace {

using namespace mlp::link;

constexpr int kPoints = 21600;  // the firmware's cloud of a 300 x 300 px face patch
constexpr int kCloudsPerIteration = 20;

// A stripe-like cloud: rows 26 um apart, 2 um noise in depth (what the firmware produces).
LinkCloud MakeCloud(int index) {
  std::mt19937 gen(static_cast<unsigned>(index));
  std::normal_distribution<double> noise(0.0, 0.002);
  LinkCloud c;
  c.capture_id = "bench-" + std::to_string(index);
  c.probe_serial = "P-1";
  c.calibration_id = "cal";
  for (int i = 0; i < kPoints; ++i) {
    const int frame = i / 300, row = i % 300;
    c.xyz.insert(c.xyz.end(), {-3.9 + 0.052 * frame, -3.9 + 0.026 * row, 120.0 + noise(gen)});
    c.quality.push_back(0.8f);
  }
  return c;
}

void SetRates(benchmark::State& state, double clouds) {
  state.counters["clouds_per_s"] = benchmark::Counter(clouds, benchmark::Counter::kIsRate);
  state.counters["Mpoints_per_s"] =
      benchmark::Counter(clouds * kPoints * 1e-6, benchmark::Counter::kIsRate);
}

void BM_PlainCopy(benchmark::State& state) {
  const LinkCloud c = MakeCloud(0);
  std::vector<double> copy(c.xyz.size());
  for (auto _ : state) {
    std::memcpy(copy.data(), c.xyz.data(), c.xyz.size() * sizeof(double));
    benchmark::DoNotOptimize(copy.data());
  }
  SetRates(state, static_cast<double>(state.iterations()));
}

void BM_CodecOnly(benchmark::State& state) {
  const LinkCloud c = MakeCloud(0);
  std::size_t bytes = 0;
  for (auto _ : state) {
    const Bytes b = EncodeCloud(c, state.range(0) != 0);
    bytes = b.size();
    benchmark::DoNotOptimize(DecodeCloud(b));
  }
  SetRates(state, static_cast<double>(state.iterations()));
  state.counters["bytes_per_point"] = static_cast<double>(bytes) / kPoints;
}

void BM_FullPathOnLoopback(benchmark::State& state) {
  std::atomic<long> delivered{0};
  HostLinkConfig hc;
  hc.probes["P-1"] = Key{Bytes(32, 7)};
  HostLink host(
      hc, [&](const LinkCloud&) { ++delivered; },
      [](const std::string& l) { std::fprintf(stderr, "host %s\n", l.c_str()); });
  // (the link logs only failures: a clean run prints nothing)
  host.Start();
  ProbeLinkConfig pc;
  pc.serial = "P-1";
  pc.key = Key{Bytes(32, 7)};
  pc.port = host.Port();
  pc.compress = state.range(0) != 0;
  ProbeLink probe(pc, [](const std::string& l) {
    if (l.find("authenticated") == std::string::npos) std::fprintf(stderr, "probe %s\n", l.c_str());
  });
  probe.Start();
  std::vector<LinkCloud> clouds;
  for (int i = 0; i < kCloudsPerIteration; ++i) clouds.push_back(MakeCloud(i));
  long round = 0;
  for (auto _ : state) {
    for (size_t i = 0; i < clouds.size(); ++i) {
      LinkCloud& c = clouds[i];
      c.capture_id = "bench-" + std::to_string(round) + "-" + std::to_string(i);
      while (probe.Submit(c) != SubmitResult::kQueued) {
      }
    }
    if (!probe.WaitAllAcknowledged(std::chrono::seconds(60))) {
      state.SkipWithError("timeout");
      break;
    }
    ++round;
  }
  SetRates(state, static_cast<double>(state.iterations() * kCloudsPerIteration));
  state.counters["bytes_per_point"] =
      static_cast<double>(EncodeCloud(clouds[0], pc.compress).size()) / kPoints;
  probe.Stop();
  host.Stop();
}

BENCHMARK(BM_PlainCopy)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CodecOnly)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FullPathOnLoopback)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
