// Issue 49: every fit on the partial features a probe really sees. A seeded sweep over windows
// (arcs 3-360 deg, caps 3-90 deg, sectors 5-360 deg), radii 1-2000 mm and 100-100,000 points
// at 2 um of noise: each fit either lands within a few of its own reported standard deviations
// of the truth, or is refused as "not determined" naming the standard deviation that made it
// refuse (a cone or an ellipse: a sector or arc under 60 deg, where their least squares has
// local minima or long valleys the solver does not leave; a cone whose fitted apex has points
// beyond it or whose RMS is over 1 % of its radius). None may
// fail to converge, none may throw anything else.
//
// The data come from tests/geometry/partial_features.h (shares no code with the fits). The
// seeds were fixed before the fits were changed for this issue; the figures in
// docs/GEOMETRY.md come from the same generator on the seeds of the `MLP_SWEEP_SEED` run.
//
// Why not "every parameter within 3 sigma": a parameter of a correct fit lies beyond 3 of its
// standard deviations in 0.27 % of draws, and the sweep makes about 4,000 such checks, so a
// handful must. The test asks what a correct uncertainty gives: none beyond 5 sigma and at
// most 1 % beyond 3 sigma.

#include "mlp/geometry/error.h"
#include "mlp/geometry/fit.h"
#include "mlp/geometry/robust.h"

#include <cstdlib>
#include <functional>
#include <iostream>
#include <sstream>

#include "fit_checks.h"
#include <gtest/gtest.h>

namespace mlp::test::partial {
namespace {

namespace g = geometry;

constexpr double kNoiseMm = 0.002;     // 2 um per axis
constexpr double kWithinSigma = 3.0;   // the check's usual bound ...
constexpr double kBeyondShare = 0.01;  // ... which at most this share of checks may exceed
constexpr double kNeverSigma = 5.0;    // and none this one
constexpr double kRoundingMm = 1e-9;   // below this an error is the data's rounding
// Every run: 16 cases a shape, up to 20,000 points (under a minute). MLP_SWEEP_FULL=1: 48 cases
// a shape up to the 100,000 points (about 9 minutes; the figures in docs/GEOMETRY.md).
bool FullSweep() { return std::getenv("MLP_SWEEP_FULL") != nullptr; }
int CasesPerShape() { return FullSweep() ? 48 : 16; }
double MostPoints() { return FullSweep() ? 100000.0 : 20000.0; }

struct Tally {
  int fitted = 0, refused = 0, checks = 0, beyond = 0;
  std::vector<std::string> failures;
};

// One fit's checks into the tally; a check whose error exceeds kNeverSigma is a failure. The
// share beyond kWithinSigma counts the least-squares fits only: a robust fit of the same clean
// points is the same fit, and counting it again would count one draw twice.
void Judge(const std::string& label,
           bool robust,
           const std::vector<ParameterCheck>& checks,
           Tally* tally) {
  const bool counted = !robust;
  ++tally->fitted;
  for (const ParameterCheck& c : checks) {
    tally->checks += counted;
    if (!(c.sigma >= 0.0)) {
      tally->failures.push_back(label + ": no standard deviation for " + c.name);
      continue;
    }
    const double bound = c.sigma + kRoundingMm;
    if (std::abs(c.error) > kWithinSigma * bound) {
      tally->beyond += counted;
      std::cout << "  beyond " << kWithinSigma << " sigma: " << label << ": " << c.name << " "
                << c.error / bound << " sigma\n";
    }
    if (std::abs(c.error) > kNeverSigma * bound) {
      std::ostringstream s;
      s << label << ": " << c.name << " off by " << c.error << " with sigma " << c.sigma;
      tally->failures.push_back(s.str());
    }
  }
}

// Runs `fit`; a refusal must say "not determined" with its standard deviation.
template <class Fit>
void Attempt(const std::string& label, const Truth& t, Fit fit, Tally* tally) {
  try {
    const auto result = fit();
    std::ostringstream with_rms;
    with_rms << label << " (rms " << result.stats.rms * 1e3 << " um)";
    Judge(with_rms.str(), label.ends_with(" robust"), Checks(result, t), tally);
  } catch (const g::GeometryError& e) {
    const std::string what = e.what();
    // Refused with the evidence: a standard deviation over its limit, or (cones) the sector,
    // the points beyond the fitted apex or the RMS against the radius.
    if (e.code() == g::ErrorCode::kDegenerate && what.find("not determined") != std::string::npos &&
        (what.find("standard deviation") != std::string::npos ||
         what.find(" deg about the fitted") != std::string::npos ||
         what.find("is not found") != std::string::npos ||
         what.find("beyond the fitted apex") != std::string::npos ||
         what.find("not on one cone") != std::string::npos)) {
      ++tally->refused;
      return;
    }
    tally->failures.push_back(label + ": " + g::ToString(e.code()) + ": " + what);
  }
}

struct Case {
  Truth truth;
  int points = 0;
  Eigen::Matrix3d frame;
  std::string Label(std::uint64_t seed) const {
    std::ostringstream s;
    s << truth.shape << " seed " << seed << " R " << truth.radius << " window " << truth.window_deg
      << " deg, " << points << " points";
    return s.str();
  }
};

// One seeded case of `shape`: its window, radius, extent and point count drawn from the ranges
// the issue names.
Case DrawCase(const std::string& shape, Draw& d) {
  Case c;
  Truth& t = c.truth;
  t.shape = shape;
  c.frame = d.Frame();
  t.axis = c.frame.col(2);
  t.major = c.frame.col(0);
  t.center = d.NormalVec(300.0);  // anywhere within a machine's travel
  t.radius = d.LogUniform(1.0, 2000.0);
  c.points = static_cast<int>(d.LogUniform(100.0, MostPoints()));
  if (shape == "circle" || shape == "ellipse") {
    t.window_deg = d.LogUniform(3.0, 360.0);
    t.minor = t.radius * d.Uniform(0.3, 0.95);
  } else if (shape == "sphere") {
    t.window_deg = d.LogUniform(3.0, 90.0);
  } else if (shape == "cylinder" || shape == "cone") {
    t.window_deg = d.LogUniform(5.0, 360.0);
    t.extent_mm = t.radius * d.LogUniform(0.2, 3.0);
    if (shape == "cone") t.half_angle = d.Uniform(5.0, 60.0) * kDeg;
  } else {
    t.extent_mm = d.LogUniform(1.0, 2000.0);
  }
  return c;
}

// The sweep's seeds: fixed before tuning. MLP_SWEEP_SEED=N runs a fresh set (the figures in
// docs/GEOMETRY.md).
std::uint64_t FirstSeed() {
  const char* s = std::getenv("MLP_SWEEP_SEED");
  return s != nullptr ? std::strtoull(s, nullptr, 10) : 4900;
}

using Runner = std::function<void(const std::string&, const Truth&, const Points&, Tally*)>;

void Sweep(const std::string& shape, const Runner& run) {
  Tally tally;
  const std::uint64_t first = FirstSeed();
  for (int k = 0; k < CasesPerShape(); ++k) {
    const std::uint64_t seed = first + static_cast<std::uint64_t>(k);
    std::uint64_t salt = 0;  // the shape's own draws (not std::hash: its values are the library's)
    for (const char ch : shape) salt = salt * 31 + static_cast<unsigned char>(ch);
    Draw d(seed * 7919 + salt);
    const Case c = DrawCase(shape, d);
    const Points p = Sample(c.truth, c.points, kNoiseMm, c.frame, d);
    run(c.Label(seed), c.truth, p, &tally);
  }
  std::cout << shape << ": " << tally.fitted << " fitted, " << tally.refused
            << " refused as not determined; " << tally.beyond << " of " << tally.checks
            << " parameter checks beyond " << kWithinSigma << " sigma\n";
  for (const std::string& f : tally.failures) ADD_FAILURE() << f;
  EXPECT_LE(tally.beyond, kBeyondShare * tally.checks + 1) << shape;
  EXPECT_GT(tally.fitted, 0) << shape;
}

// A robust fit's least-squares result, for the checks.
template <class Shape>
g::FitResult<Shape> Inner(const g::RobustFitResult<Shape>& r) {
  return r.fit;
}

TEST(PartialSweep, CirclesInSpaceBothDefinitionsLsAndRobust) {
  Sweep("circle", [](const std::string& label, const Truth& t, const Points& p, Tally* tally) {
    for (const auto def :
         {g::Circle3Definition::kSpatial, g::Circle3Definition::kPlaneThenCircle}) {
      g::FitOptions o;
      o.circle3 = def;
      const std::string tag =
          label + (def == g::Circle3Definition::kSpatial ? " spatial" : " plane-then-circle");
      Attempt(
          tag + " ls", t, [&] { return g::FitCircle3(p, o); }, tally);
      g::RobustOptions r;
      r.least_squares = o;
      if (p.cols() <= 20000)
        Attempt(
            tag + " robust", t, [&] { return Inner(g::FitCircle3Robust(p, r)); }, tally);
    }
  });
}

// The least-squares fit, and the robust one on clouds up to `robust_points` (the robust ones
// score every sample on every point).
template <class Ls, class Robust>
Runner LsAndRobust(Ls ls, Robust robust, Eigen::Index robust_points = 20000) {
  return [=](const std::string& label, const Truth& t, const Points& p, Tally* tally) {
    Attempt(
        label + " ls", t, [&] { return ls(p); }, tally);
    if (p.cols() <= robust_points)
      Attempt(
          label + " robust", t, [&] { return Inner(robust(p)); }, tally);
  };
}

TEST(PartialSweep, SpheresOnCaps) {
  Sweep("sphere", LsAndRobust([](const Points& p) { return g::FitSphere(p); },
                              [](const Points& p) { return g::FitSphereRobust(p); }));
}

TEST(PartialSweep, CylindersOnSectors) {
  Sweep("cylinder", LsAndRobust([](const Points& p) { return g::FitCylinder(p); },
                                [](const Points& p) { return g::FitCylinderRobust(p); }));
}

TEST(PartialSweep, ConesOnSectors) {
  Sweep("cone", LsAndRobust([](const Points& p) { return g::FitCone(p); },
                            [](const Points& p) { return g::FitConeRobust(p); }));
}

TEST(PartialSweep, EllipsesOnArcs) {
  // The robust ellipse scores each sample by exact foot points on every point: a few thousand
  // points keep this test under a minute.
  Sweep("ellipse", LsAndRobust([](const Points& p) { return g::FitEllipse3(p); },
                               [](const Points& p) { return g::FitEllipse3Robust(p); }, 3000));
}

TEST(PartialSweep, LinesAndPlanes) {
  Sweep("line", LsAndRobust([](const Points& p) { return g::FitLine3(p); },
                            [](const Points& p) { return g::FitLine3Robust(p); }));
  Sweep("plane", LsAndRobust([](const Points& p) { return g::FitPlane(p); },
                             [](const Points& p) { return g::FitPlaneRobust(p); }));
}

}  // namespace
}  // namespace mlp::test::partial
