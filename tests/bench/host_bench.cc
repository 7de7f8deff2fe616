// Host-side time from the last cloud received to the decision written (issue 6: under 20 ms),
// doing what mlp-hostd's jobs do: read the stored clouds (PLY) and check their SHA-256, map
// them into the machine frame, segment and fit, decide, pass the plausibility gate, write the
// controller's file (atomic) and the history rows (SQLite), and draw the report. Bore: 50,000
// wall points in four captures; six-point alignment: a face (3 x 5,000 points) and two holes
// (4 x 6,000 each). Baseline in the same run: one read of the 50,000 points.
// Run: build/bin/mlp_host_bench --benchmark_counters_tabular=true

#include "mlp/base/files.h"
#include "mlp/features/composite.h"
#include "mlp/features/decision.h"
#include "mlp/features/feature.h"
#include "mlp/features/report.h"
#include "mlp/features/surface.h"
#include "mlp/geometry/datum.h"
#include "mlp/history/file_hash.h"
#include "mlp/history/history.h"
#include "mlp/nc/nc_output.h"
#include "mlp/nc/tool_table.h"
#include "mlp/probe_fw/cloud_file.h"

#include <filesystem>
#include <random>

#include "../features/feature_points.h"
#include <benchmark/benchmark.h>

namespace {

namespace fs = std::filesystem;
using mlp::geometry::Points3;
using mlp::geometry::Vec3;

constexpr double kNoiseMm = 0.002;
const fs::path kDir = fs::temp_directory_path() / "mlp_host_bench";

// Wall points of a vertical bore of `diameter` at (cx, cy) in four 20-degree patches, written
// as four capture files (probe frame = machine frame: H = M = identity).
std::vector<std::string> WriteHole(const std::string& name,
                                   double cx,
                                   double cy,
                                   double diameter,
                                   int per_capture,
                                   unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::uniform_real_distribution<double> along(-0.17, 0.17), depth(-18, -2);
  std::vector<std::string> files;
  for (int q = 0; q < 4; ++q) {
    std::vector<double> xyz;
    std::vector<float> quality;
    for (int i = 0; i < per_capture; ++i) {
      const double a = q * M_PI / 2 + along(rng), r = diameter / 2 + noise(rng);
      xyz.insert(xyz.end(), {cx + r * std::cos(a), cy + r * std::sin(a), depth(rng)});
      quality.push_back(1.0f);
    }
    const std::string path = (kDir / (name + std::to_string(q) + ".ply")).string();
    mlp::probe_fw::WriteCloudPly(
        path, xyz, quality, {"P", "c", name, Eigen::Isometry3d::Identity(), "probe", std::nullopt});
    files.push_back(path);
  }
  return files;
}

std::vector<std::string> WriteFace(int per_capture) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0, kNoiseMm);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  std::vector<std::string> files;
  const double spots[3][2] = {{-15, 30}, {100, -15}, {100, 75}};
  for (int s = 0; s < 3; ++s) {
    std::vector<double> xyz;
    std::vector<float> quality(static_cast<size_t>(per_capture), 1.0f);
    for (int i = 0; i < per_capture; ++i)
      xyz.insert(xyz.end(), {spots[s][0] + u(rng), spots[s][1] + u(rng), noise(rng)});
    const std::string path = (kDir / ("face" + std::to_string(s) + ".ply")).string();
    mlp::probe_fw::WriteCloudPly(path, xyz, quality, {"P", "c", "face", {}, "probe", std::nullopt});
    files.push_back(path);
  }
  return files;
}

// What the job does with its stored captures: hash check, read, gather.
Points3 Load(const std::vector<std::string>& files, const std::vector<std::string>& hashes) {
  std::vector<double> all;
  for (size_t k = 0; k < files.size(); ++k) {
    if (mlp::history::Sha256OfFile(files[k]) != hashes[k]) throw std::runtime_error("changed");
    const auto f = mlp::probe_fw::ReadCloudPly(files[k]);
    all.insert(all.end(), f.xyz.begin(), f.xyz.end());
  }
  return Eigen::Map<const Points3>(all.data(), 3, static_cast<Eigen::Index>(all.size() / 3));
}

std::vector<std::string> Hashes(const std::vector<std::string>& files) {
  std::vector<std::string> h;
  for (const auto& f : files) h.push_back(mlp::history::Sha256OfFile(f));
  return h;
}

void BM_MemoryReadBaseline(benchmark::State& state) {
  fs::create_directories(kDir);
  const auto files = WriteHole("base", 0, 0, 60, 12500, 1);
  const Points3 p = Load(files, Hashes(files));
  for (auto _ : state) benchmark::DoNotOptimize(p.rowwise().sum().eval());
}

void BM_BoreJobHostSide(benchmark::State& state) {
  fs::create_directories(kDir);
  const auto files = WriteHole("bore", 0, 0, 60, 12500, 2);
  const auto hashes = Hashes(files);
  mlp::history::History history((kDir / "history.sqlite").string());
  mlp::features::BoreNominal n;
  n.diameter_mm = 60.01, n.depth_mm = 20;
  mlp::features::Feedback f;
  f.offset_number = 12;
  f.null_band_mm = 0.002;
  for (auto _ : state) {
    const auto job = history.StartJob({"vmc", "measure", "P", "cal", {{"feature", "bore"}}});
    const Points3 p = Load(files, hashes);
    for (size_t k = 0; k < files.size(); ++k)
      history.AddCapture(job, {"c", nlohmann::json::object(), files[k], hashes[k], 12500});
    const auto bore = mlp::features::MeasureBore(p, n);
    const auto d = mlp::features::DecideSize(bore.diameter_mm, {60.01, 0.02, 0.02}, f);
    mlp::features::FitEvidence e;
    e.points = bore.points, e.rms_mm = bore.rms_mm, e.arc_span_deg = bore.arc_span_deg;
    e.calibration_probe = e.job_probe = "P";
    e.offset_changes_mm = {d.offset_change_mm};
    if (!mlp::features::PlausibilityProblems(e, {}).empty()) state.SkipWithError("refused");
    mlp::nc::NcResult out;
    out.tools.push_back(
        {12, mlp::nc::ToolRegister::kRadiusGeometry, 5.0, 5.0 + d.offset_change_mm, false});
    mlp::base::WriteFileAtomically((kDir / "mlp_result.ngc").string(),
                                   mlp::nc::LinuxCncSubroutine("mlp_result", out));
    history.AddResult(job, {"bore", {{"d", bore.diameter_mm}}, {{"change", d.offset_change_mm}}});
    mlp::features::BoreReport rep;
    rep.bore = bore;
    mlp::base::WriteFileAtomically((kDir / "report.svg").string(),
                                   mlp::features::BoreReportSvg(rep));
    history.FinishJob(job, mlp::history::JobStatus::kInTolerance, {{"ok", true}}, {});
    state.counters["diameter_error_um"] = (bore.diameter_mm - 60.0) * 1e3;
  }
  state.counters["points"] = 50000;
}

void BM_AlignJobHostSide(benchmark::State& state) {
  fs::create_directories(kDir);
  const auto face = WriteFace(5000);
  const auto b = WriteHole("b", 0, 0, 20, 6000, 3), c = WriteHole("c", 0, 60, 20, 6000, 4);
  const auto hf = Hashes(face), hb = Hashes(b), hc = Hashes(c);
  mlp::features::BoreNominal nb, nc;
  nb.diameter_mm = nc.diameter_mm = 20, nb.depth_mm = nc.depth_mm = 20;
  nc.top_centre_mcs = Vec3(0, 60, 0);
  for (auto _ : state) {
    const auto plane = mlp::features::MeasurePlane(Load(face, hf), {}).plane;
    const auto pb = mlp::features::MeasureBore(Load(b, hb), nb);
    const auto pc = mlp::features::MeasureBore(Load(c, hc), nc);
    const auto w = mlp::geometry::ReadWorkOffset(
        mlp::geometry::DatumPlaneCircleCircle(plane, pb.top_centre_mcs, pc.top_centre_mcs));
    mlp::nc::NcResult out;
    out.work.push_back({1,
                        {0, 0, 0},
                        {w.origin_mm.x(), w.origin_mm.y(), w.origin_mm.z()},
                        std::nullopt,
                        w.rotation_z_deg});
    mlp::base::WriteFileAtomically((kDir / "mlp_result.ngc").string(),
                                   mlp::nc::LinuxCncSubroutine("mlp_result", out));
    state.counters["origin_error_um"] = w.origin_mm.norm() * 1e3;
  }
  state.counters["points"] = 15000 + 2 * 24000;
}

// The fits of the other features alone (no files, no writes), at the sizes their planned
// captures give: what they add to a job against the bore's.
void BM_RectanglePocketFit(benchmark::State& state) {
  mlp::features::test::CloudMaker cloud(5, kNoiseMm);
  for (double s : {1.0, -1.0}) {
    cloud.Patch(Vec3(s * 30, -4, -11.5), Vec3::UnitY(), Vec3::UnitZ(), 8, 8, 12500);
    cloud.Patch(Vec3(-4, s * 20, -11.5), Vec3::UnitX(), Vec3::UnitZ(), 8, 8, 12500);
  }
  const Points3 p = cloud.Cloud();
  mlp::features::RectangleNominal n;
  n.centre_mcs = Vec3(0, 0, -7.5), n.size_x_mm = 60, n.size_y_mm = 40, n.within_mm = 6;
  for (auto _ : state) benchmark::DoNotOptimize(mlp::features::MeasureRectangle(p, n));
  state.counters["points"] = 50000;
}

void BM_PcdFit(benchmark::State& state) {
  mlp::features::test::CloudMaker cloud(6, kNoiseMm);
  mlp::features::PcdNominal n;
  n.diameter_mm = 30;
  for (int k = 0; k < 4; ++k) {
    const Vec3 at = 15 * mlp::features::test::Dir(90 * k);
    cloud.Wall(at.x(), at.y(), 4, -10, -2, 0, 360, 12500);
    mlp::features::BoreNominal h;
    h.top_centre_mcs = at, h.diameter_mm = 8, h.depth_mm = 12;
    n.holes.push_back(h);
  }
  const Points3 p = cloud.Cloud();
  for (auto _ : state) benchmark::DoNotOptimize(mlp::features::MeasurePcd(p, n));
  state.counters["points"] = 50000;
}

void BM_SurfacePatchAgainstNominal(benchmark::State& state) {
  // A flat 20 x 20 mm nominal every 0.25 mm (6,561 vector points), 50,000 measured points.
  mlp::features::SurfaceNominal n;
  n.spacing_mm = 0.25;
  n.points_mcs.resize(3, 81 * 81), n.normals_mcs.resize(3, 81 * 81);
  for (int i = 0; i < 81; ++i)
    for (int j = 0; j < 81; ++j) {
      n.points_mcs.col(i * 81 + j) = Vec3(-10 + 0.25 * i, -10 + 0.25 * j, 0);
      n.normals_mcs.col(i * 81 + j) = Vec3::UnitZ();
    }
  mlp::features::test::CloudMaker cloud(7, kNoiseMm);
  cloud.Patch(Vec3(-10, -10, 0), Vec3::UnitX(), Vec3::UnitY(), 20, 20, 50000);
  const Points3 p = cloud.Cloud();
  for (auto _ : state) benchmark::DoNotOptimize(mlp::features::MeasureSurface(p, n));
  state.counters["points"] = 50000;
}

BENCHMARK(BM_MemoryReadBaseline)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RectanglePocketFit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PcdFit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_SurfacePatchAgainstNominal)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BoreJobHostSide)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AlignJobHostSide)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
