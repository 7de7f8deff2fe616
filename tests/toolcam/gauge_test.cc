// Issue 52: round parts gauged from real back-lit images against a CMM
// (samples/data/backlit-washers: 20 washer-type steel parts, telecentric, dust and burrs as
// they were). Each part is predicted with the scale and edge bias fitted on the other 19
// (leave one out), as a gauge set with masters then measuring a part it did not see. A plain
// baseline in the same run: whole-pixel edges (a dark pixel with a light 4-neighbour at the
// half level) and one algebraic (Kasa) circle per radius cluster, through the same scale fit.

#include "mlp/toolcam/gauge.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.h"
#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

namespace mlp::toolcam {
namespace {

using geometry::Vec2;

const std::filesystem::path kData = mlp::test::RepoDataDir() / "backlit-washers";
constexpr int kParts = 20;
constexpr double kOuterRmsUm = 6.4, kInnerRmsUm = 9.0;  // leave one out, measured + 15 %
constexpr double kConcentricityCorr = 0.83;

struct Cmm {
  MasterFigures d;
  double concentricity_mm = 0.0;
  double outer_roundness_mm = 0.0, inner_roundness_mm = 0.0;
};

std::vector<Cmm> ReadCmm() {
  std::ifstream in(kData / "cmm.csv");
  std::string line;
  std::getline(in, line);  // the header
  std::vector<Cmm> out;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream s(line);
    for (std::string f; std::getline(s, f, ',');) v.push_back(std::stod(f));
    if (v.size() < 10) continue;
    out.push_back({{v[5], v[1]}, v[9], v[8], v[4]});
  }
  return out;
}

cv::Mat Image(int part) {
  char name[32];
  std::snprintf(name, sizeof name, "part_%02d.png", part);
  return cv::imread((kData / name).string(), cv::IMREAD_GRAYSCALE);
}

// The plain baseline: whole-pixel edges, the two clusters split at the radii's middle, one
// algebraic circle each; nothing of the gauge's code.
GaugedPart Plain(const cv::Mat& m) {
  const geometry::GreyView g{m.data, m.cols, m.rows, 0};
  const double level = geometry::HalfLevel(g);
  std::vector<Vec2> edge;
  for (int v = 1; v + 1 < m.rows; ++v)
    for (int u = 1; u + 1 < m.cols; ++u)
      if (g.At(u, v) < level && (g.At(u - 1, v) >= level || g.At(u + 1, v) >= level ||
                                 g.At(u, v - 1) >= level || g.At(u, v + 1) >= level))
        edge.emplace_back(u, v);
  Vec2 c = Vec2::Zero();
  for (const Vec2& p : edge) c += p / static_cast<double>(edge.size());
  double mean_r = 0;
  for (const Vec2& p : edge) mean_r += (p - c).norm() / static_cast<double>(edge.size());
  std::vector<Vec2> clusters[2];
  for (const Vec2& p : edge) clusters[(p - c).norm() < mean_r].push_back(p);
  GaugedPart part;
  for (int k = 0; k < 2; ++k) {
    // Kasa's algebraic circle: x^2 + y^2 = 2 a x + 2 b y + c, linear least squares.
    const auto n = static_cast<Eigen::Index>(clusters[k].size());
    Eigen::MatrixXd a(n, 3);
    Eigen::VectorXd b(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Vec2& p = clusters[k][static_cast<size_t>(i)];
      a.row(i) << 2 * p.x(), 2 * p.y(), 1.0;
      b(i) = p.squaredNorm();
    }
    const Eigen::Vector3d x = a.colPivHouseholderQr().solve(b);
    GaugedCircle& gc = k == 0 ? part.outer : part.inner;
    gc.centre_px = x.head<2>();
    gc.diameter_px = 2 * std::sqrt(x(2) + x.head<2>().squaredNorm());
  }
  return part;
}

struct Scores {
  double outer_rms_um = 0, inner_rms_um = 0, outer_max_um = 0, inner_max_um = 0;
  double concentricity_corr = 0;
  double roundness_rms_um = 0;  // both circles' roundness against the CMM's
};

Scores LeaveOneOut(const std::vector<GaugedPart>& parts, const std::vector<Cmm>& cmm) {
  Scores s;
  std::vector<double> found, truth;
  for (size_t j = 0; j < parts.size(); ++j) {
    std::vector<GaugedPart> p;
    std::vector<MasterFigures> m;
    for (size_t i = 0; i < parts.size(); ++i)
      if (i != j) p.push_back(parts[i]), m.push_back(cmm[i].d);
    const PartFigures f = ToMillimetres(parts[j], FitGaugeScale(p, m));
    const double eo = (f.outer_diameter_mm - cmm[j].d.outer_diameter_mm) * 1e3;
    const double ei = (f.inner_diameter_mm - cmm[j].d.inner_diameter_mm) * 1e3;
    s.outer_rms_um += eo * eo / static_cast<double>(parts.size());
    s.inner_rms_um += ei * ei / static_cast<double>(parts.size());
    s.outer_max_um = std::max(s.outer_max_um, std::abs(eo));
    s.inner_max_um = std::max(s.inner_max_um, std::abs(ei));
    found.push_back(f.concentricity_mm), truth.push_back(cmm[j].concentricity_mm);
    s.roundness_rms_um += (std::pow(f.outer_roundness_mm - cmm[j].outer_roundness_mm, 2) +
                           std::pow(f.inner_roundness_mm - cmm[j].inner_roundness_mm, 2)) *
                          1e6 / static_cast<double>(2 * parts.size());
  }
  s.outer_rms_um = std::sqrt(s.outer_rms_um), s.inner_rms_um = std::sqrt(s.inner_rms_um);
  s.roundness_rms_um = std::sqrt(s.roundness_rms_um);
  const auto n = static_cast<double>(found.size());
  double mf = 0, mt = 0;
  for (size_t i = 0; i < found.size(); ++i) mf += found[i] / n, mt += truth[i] / n;
  double sff = 0, stt = 0, sft = 0;
  for (size_t i = 0; i < found.size(); ++i) {
    sff += (found[i] - mf) * (found[i] - mf), stt += (truth[i] - mt) * (truth[i] - mt);
    sft += (found[i] - mf) * (truth[i] - mt);
  }
  s.concentricity_corr = sft / std::sqrt(sff * stt);
  return s;
}

TEST(Gauge, TwentyRealWashersAgainstTheirCmmLeaveOneOut) {
  const std::vector<Cmm> cmm = ReadCmm();
  ASSERT_EQ(cmm.size(), static_cast<size_t>(kParts));
  std::vector<GaugedPart> parts, plain;
  int left_out = 0, stray = 0;
  for (int k = 1; k <= kParts; ++k) {
    const cv::Mat m = Image(k);
    ASSERT_FALSE(m.empty()) << k;
    parts.push_back(GaugeRing({m.data, m.cols, m.rows, 0}));  // none refused
    left_out += parts.back().outer.left_out + parts.back().inner.left_out;
    stray += parts.back().stray_points;
    plain.push_back(Plain(m));
  }
  const Scores ours = LeaveOneOut(parts, cmm), base = LeaveOneOut(plain, cmm);
  std::vector<MasterFigures> all;
  for (const Cmm& c : cmm) all.push_back(c.d);
  const GaugeScale scale = FitGaugeScale(parts, all);
  std::printf(
      "scale on all 20: %.6f mm/px, edge bias %.2f um, masters' rms %.2f um; "
      "roundness against the CMM's %.2f um RMS\n",
      scale.mm_per_px, scale.edge_bias_mm * 1e3, scale.rms_mm * 1e3, ours.roundness_rms_um);
  std::printf(
      "gauge, 20 real parts, leave one out: outer %.2f um RMS (max %.2f), inner %.2f um RMS "
      "(max %.2f), concentricity correlation %.3f; %d edge points left out on the circles, %d "
      "stray\nplain baseline, same run: outer %.2f um RMS (max %.2f), inner %.2f (max %.2f), "
      "concentricity correlation %.3f\n",
      ours.outer_rms_um, ours.outer_max_um, ours.inner_rms_um, ours.inner_max_um,
      ours.concentricity_corr, left_out, stray, base.outer_rms_um, base.outer_max_um,
      base.inner_rms_um, base.inner_max_um, base.concentricity_corr);
  EXPECT_LE(ours.outer_rms_um, base.outer_rms_um);  // never lose to the plain baseline
  EXPECT_LE(ours.inner_rms_um, base.inner_rms_um);
  EXPECT_GE(ours.concentricity_corr, base.concentricity_corr);
  // Measured 5.58 / 7.83 um RMS and 0.866 (2026-11-28): held at that, +15 %. Issue 52 asks
  // 3 / 8 um and 0.95; an outside plain pipeline reached 4.4 / 9.1 um and 0.92: the outer
  // diameter and the concentricity are not there yet (docs/TOOLCAM.md).
  EXPECT_LT(ours.outer_rms_um, kOuterRmsUm);
  EXPECT_LT(ours.inner_rms_um, kInnerRmsUm);
  EXPECT_GT(ours.concentricity_corr, kConcentricityCorr);
}

// No part, or half of one: refused, never a diameter.
TEST(Gauge, AnImageWithoutARingIsRefused) {
  std::vector<std::uint8_t> light(640 * 480, 200);
  EXPECT_THROW(GaugeRing({light.data(), 640, 480, 0}), GaugeError);
  const cv::Mat m = Image(1);
  const cv::Mat left = m(cv::Rect(0, 0, 700, m.rows)).clone();  // an arc of each circle
  EXPECT_THROW(GaugeRing({left.data, left.cols, left.rows, 0}), GaugeError);
}

}  // namespace
}  // namespace mlp::toolcam
