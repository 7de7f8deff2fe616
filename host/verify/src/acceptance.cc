#include "mlp/verify/acceptance.h"

#include "mlp/base/input_error.h"
#include "mlp/base/units.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/geometry/fit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <random>
#include <thread>

#include "views.h"
#include <Eigen/Geometry>

namespace mlp::verify {
namespace {

using base::kArcsecPerRad;
using base::kDegPerRad;
// The virtual machine's true mounting M (the demo's): the host never reads it.
const Vec3 kTrueMountTranslationMm(4.0, -2.5, 35.0);
const Vec3 kTrueMountRotationVector(0.0185, 0.0185, 0.0);
// Where the artefacts stand in the machine [mm].
const Vec3 kReferenceSphereMcs(180.0, 150.0, -300.0);
const Vec3 kGaugeCentreMcs(300.0, 150.0, -260.0);
// Views look at a sphere from within this cone about the vertical (a five-axis head).
constexpr double kMaxTiltRad = 30.0 / kDegPerRad;
// Probing views: the sphere's nearest point between these standoffs, across the working range.
constexpr double kNearStandoffMm = 110.0, kFarStandoffMm = 130.0;
constexpr double kGaugeStandoffMm = 120.0;
// How far the sphere's centre lies off the optical axis [mm]: hand-eye views (up to ~110 px), and
// the most for probing and gauge views.
constexpr double kHandEyeOffsetMm = 3.0, kMaxOffsetMm = 2.0;
// Windows. The sphere's image is ~890 px across at 120 mm: 400 px reads the cap within ~27 deg of
// the view (the hand-eye's and the gauge's centres need no more). A probing view reads the
// square whose corners lie on the cap 65 deg from the view (45 deg along its sides), whatever
// the standoff: form and size are judged over as much of the sphere as a view shows well; the
// rim beyond, lit and seen at grazing angles, mixes sphere and background in a pixel.
constexpr int kCentreAoiPx = 400;
constexpr double kProbingCapDeg = 65.0;

int ProbingWindowPx(const probe_fw::ProbeModel& model, double radius_mm, double standoff_mm) {
  const double cap_px = model.camera.fx_px * radius_mm * std::sin(kProbingCapDeg / kDegPerRad) /
                        (standoff_mm + radius_mm);
  return 2 * static_cast<int>(cap_px / std::sqrt(2.0));
}
// A view's points farther than this from the sphere where the host expects it (its nominal
// place through the host's M: good to some 10 um) are another object's, the table, a stem or a
// neighbour seen past the sphere's rim: the sphere is segmented by its nominal place, as a
// measuring program does, before any figure; they are counted.
constexpr double kSegmentationGateMm = 1.0;
constexpr int kFormSubsetPoints = 25;      // ISO 10360-8's 1 x 25
constexpr double kDispersionShare = 0.95;  // ISO 10360-8's D95%
// The window over which the calibrated frame is compared with the true one: where the spheres'
// views read.
const probe_fw::Aoi kSphereWindow{824, 568, 400, 400};

Pose3 TrueMount() {
  Pose3 m = Pose3::Identity();
  m.linear() =
      Eigen::AngleAxisd(kTrueMountRotationVector.norm(), kTrueMountRotationVector.normalized())
          .toRotationMatrix();
  m.translation() = kTrueMountTranslationMm;
  return m;
}

// The mounting as drawn (what the host plans the hand-eye views with): no tilt.
Pose3 DesignMount() {
  Pose3 m = Pose3::Identity();
  m.translation() = kTrueMountTranslationMm;
  return m;
}

// Runs job(i) for i in [0, n) on every core; the jobs are independent and seeded by i, so the
// result does not depend on the order.
template <typename Job>
void ForEachView(int n, const Job& job) {
  const int workers =
      std::max(1, std::min<int>(n, static_cast<int>(std::thread::hardware_concurrency())));
  std::atomic<int> next{0};
  std::mutex error_mutex;
  std::exception_ptr error;
  auto work = [&] {
    for (int i = next++; i < n; i = next++) {
      try {
        job(i);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> threads;
  for (int w = 1; w < workers; ++w) threads.emplace_back(work);
  work();
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
}

// Views run on several threads: one message at a time.
void Progress(const AcceptanceOptions& o, const std::string& what) {
  static std::mutex mutex;
  const std::lock_guard<std::mutex> lock(mutex);
  if (o.progress) o.progress(what);
}

double Range(const std::vector<double>& r) {
  const auto [lo, hi] = std::minmax_element(r.begin(), r.end());
  return *hi - *lo;
}

std::vector<double> RadialResiduals(const geometry::Points3& p, const geometry::Sphere& s) {
  std::vector<double> r(static_cast<size_t>(p.cols()));
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    r[static_cast<size_t>(i)] = geometry::SignedDistance(s, p.col(i));
  return r;
}

// Farthest-point sampling: `n` points spread evenly over the measured cap, starting from the
// point nearest the cap's middle (ISO 10360-8 asks for 25 points representative of the cap).
geometry::Points3 EvenSubset(const geometry::Points3& p, int n) {
  const Vec3 mean = p.rowwise().mean();
  std::vector<double> d2(static_cast<size_t>(p.cols()));
  Eigen::Index first = 0;
  (p.colwise() - mean).colwise().squaredNorm().minCoeff(&first);
  geometry::Points3 out(3, n);
  Eigen::Index pick = first;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    d2[static_cast<size_t>(i)] = (p.col(i) - p.col(pick)).squaredNorm();
  out.col(0) = p.col(pick);
  for (int k = 1; k < n; ++k) {
    pick = std::max_element(d2.begin(), d2.end()) - d2.begin();
    out.col(k) = p.col(pick);
    for (Eigen::Index i = 0; i < p.cols(); ++i)
      d2[static_cast<size_t>(i)] =
          std::min(d2[static_cast<size_t>(i)], (p.col(i) - p.col(pick)).squaredNorm());
  }
  return out;
}

// The points of a view on its sphere: within the gate of where the host expects it.
geometry::Points3 SpherePoints(const View& view, double radius_mm, int* set_aside) {
  std::vector<Eigen::Index> keep;
  const geometry::Points3& p = view.points_in_probe;
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    if (std::abs((p.col(i) - view.planned_centre_in_probe).norm() - radius_mm) <=
        kSegmentationGateMm)
      keep.push_back(i);
  *set_aside += static_cast<int>(p.cols()) - static_cast<int>(keep.size());
  if (keep.size() < 100)
    throw VerifyError("a view gave " + std::to_string(keep.size()) + " points on its sphere");
  return p(Eigen::all, keep);
}

// The ISO 10360-8 probing figures of one view [um].
ProbingView ProbingFigures(const geometry::Points3& points, double diameter_mm) {
  ProbingView v;
  v.points = static_cast<int>(points.cols());
  const auto all = geometry::FitSphere(points);
  std::vector<double> r = RadialResiduals(points, all.shape);
  v.form_all_um = Range(r) * 1e3;
  v.size_all_um = (2 * all.shape.radius - diameter_mm) * 1e3;
  v.rms_um = all.stats.rms * 1e3;
  // D95%: the 5 % of points farthest from the sphere set aside, the rest's range.
  std::sort(r.begin(), r.end(), [](double a, double b) { return std::abs(a) < std::abs(b); });
  r.resize(static_cast<size_t>(std::ceil(kDispersionShare * static_cast<double>(r.size()))));
  v.form_d95_um = Range(r) * 1e3;
  const geometry::Points3 subset = EvenSubset(points, kFormSubsetPoints);
  const auto few = geometry::FitSphere(subset);
  v.form_1x25_um = Range(RadialResiduals(subset, few.shape)) * 1e3;
  v.size_1x25_um = (2 * few.shape.radius - diameter_mm) * 1e3;
  return v;
}

struct Machine {
  sim::AsBuiltProbe as_built;
  probe_fw::ProbeModel calibrated;
  Pose3 true_m_in_calibrated_frame = Pose3::Identity();
  double frame_rms_mm = 0.0;  ///< the calibrated frame against the true one, over kSphereWindow
};

// The hand-eye through the chain: the reference sphere (matt) from views around a cone.
calib::HandEyeResult CalibrateHandEye(const AcceptanceOptions& o, const Machine& m) {
  const double radius = o.sphere_diameter_mm / 2;
  const sim::Scene scene =
      SpheresOnStems({kReferenceSphereMcs}, o.sphere_diameter_mm, "matt_coated");
  const ViewChain chain{&m.as_built, &m.calibrated, TrueMount(), DesignMount()};
  std::vector<calib::SphereCapture> captures(static_cast<size_t>(o.hand_eye_views));
  ForEachView(o.hand_eye_views, [&](int i) {
    Progress(o, "hand-eye view " + std::to_string(i + 1) + "/" + std::to_string(o.hand_eye_views));
    // Six at 25 deg around the cone and the rest steeper, each turned differently about its
    // view: the rotations the sphere method needs to tell M's rotation from its translation.
    ViewPlan plan;
    plan.tilt_rad = (i < 6 ? 25.0 : 10.0) / kDegPerRad;
    plan.azimuth_rad = (i < 6 ? i * 60.0 : 30.0 + i * 137.5) / kDegPerRad;
    plan.spin_rad = (i * 47.0 - 90.0) / kDegPerRad;
    // The sphere at different places of the field and depths: seen always at one place of the
    // probe frame, the captures would leave M's rotation about that place free.
    plan.standoff_mm = kNearStandoffMm + (i % 3) * (kFarStandoffMm - kNearStandoffMm) / 2;
    plan.offset_mm = kHandEyeOffsetMm * geometry::Vec2(std::cos(i * 2.4), std::sin(i * 2.4));
    const View v = RenderView(chain, scene, kReferenceSphereMcs, radius, plan, 1.0,
                              o.seed * 1000 + static_cast<std::uint64_t>(i));
    auto& c = captures[static_cast<size_t>(i)];
    c.id = "reference-" + std::to_string(i);
    c.mcs_from_flange = v.mcs_from_flange;
    c.points_in_probe = v.points_in_probe;
  });
  calib::HandEyeOptions he;
  he.sphere_radius_mm = radius;
  he.leave_one_out = false;
  return calib::SolveSphereHandEye(captures, he);
}

ViewPlan RandomPlan(std::mt19937_64& rng, double standoff_mm) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  ViewPlan p;
  p.tilt_rad = kMaxTiltRad * std::sqrt(unit(rng));  // even over the cone's solid angle
  p.azimuth_rad = 2 * M_PI * unit(rng);
  p.spin_rad = 2 * M_PI * unit(rng);
  p.standoff_mm = standoff_mm;
  // One draw per statement, y first: the order GCC gave the former one-expression form (C++
  // leaves it open), so the views stay as they were on every compiler.
  const double offset_y = 2 * unit(rng) - 1;
  const double offset_x = 2 * unit(rng) - 1;
  p.offset_mm = kMaxOffsetMm * geometry::Vec2(offset_x, offset_y);
  p.aoi_px = kCentreAoiPx;
  return p;
}

void ProbingTest(const AcceptanceOptions& o, const ViewChain& chain, FinishResult* out) {
  const double radius = o.sphere_diameter_mm / 2;
  const Vec3 centre = kReferenceSphereMcs + Vec3(0, 60, 0);
  const sim::Scene scene = SpheresOnStems({centre}, o.sphere_diameter_mm, out->finish.material);
  out->views.resize(static_cast<size_t>(o.probing_views));
  std::mt19937_64 rng(o.seed * 7919 + 1);
  std::vector<ViewPlan> plans;
  for (int i = 0; i < o.probing_views; ++i) {
    const double depth = o.probing_views > 1 ? double(i % 5) / 4.0 : 0.5;
    plans.push_back(RandomPlan(rng, kNearStandoffMm + depth * (kFarStandoffMm - kNearStandoffMm)));
    plans.back().aoi_px = ProbingWindowPx(*chain.calibrated, radius, plans.back().standoff_mm);
  }
  ForEachView(o.probing_views, [&](int i) {
    const ViewPlan& plan = plans[static_cast<size_t>(i)];
    Progress(o, out->finish.material + " probing view " + std::to_string(i + 1) + "/" +
                    std::to_string(o.probing_views));
    const View v = RenderView(chain, scene, centre, radius, plan, out->finish.exposure,
                              o.seed * 2000 + static_cast<std::uint64_t>(i));
    int aside = 0;
    ProbingView pv = ProbingFigures(SpherePoints(v, radius, &aside), o.sphere_diameter_mm);
    pv.set_aside = aside;
    pv.id = "sphere-" + std::to_string(i);
    pv.standoff_mm = plan.standoff_mm;
    pv.tilt_deg = plan.tilt_rad * kDegPerRad;
    out->views[static_cast<size_t>(i)] = pv;
  });
}

// Whether the camera and the projector both see the sphere at `centre` past the gauge's other
// spheres: the lines from its centre to either lie clear of every other sphere by a margin. The
// host plans the gauge's views so (it knows where the gauge stands), as an operator would.
constexpr double kClearanceMm = 4.0;
constexpr int kPlanAttempts = 200;

double SegmentDistance(const Vec3& a, const Vec3& b, const Vec3& q) {
  const Vec3 ab = b - a;
  const double t = std::clamp((q - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + t * ab - q).norm();
}

bool Unobstructed(const ViewPlan& plan,
                  const std::vector<Vec3>& centres,
                  size_t k,
                  double radius,
                  const probe_fw::ProbeModel& model) {
  const Pose3 probe = McsFromProbe(centres[k], radius, plan);
  for (const Vec3& eye : {Vec3(probe.translation()), Vec3(probe * model.projector.Center())}) {
    for (size_t j = 0; j < centres.size(); ++j)
      if (j != k && SegmentDistance(centres[k], eye, centres[j]) < 2 * radius + kClearanceMm)
        return false;
  }
  return true;
}

struct Orientation {
  const char* name;
  Vec3 direction;
};

// ISO 10360-2's seven: the three axes and the four space diagonals. The vertical is taken 60 deg
// up from the table: spheres stacked plumb would hide each other from a probe looking down.
std::vector<Orientation> GaugeOrientations(int n) {
  const double s = std::sqrt(1.0 / 3.0), c60 = 0.5 / std::sqrt(2.0), s60 = std::sqrt(3.0) / 2;
  std::vector<Orientation> all = {
      {"X", {1, 0, 0}},     {"Y", {0, 1, 0}},     {"Z60", {c60, c60, s60}}, {"XYZ", {s, s, s}},
      {"-XYZ", {-s, s, s}}, {"X-YZ", {s, -s, s}}, {"-X-YZ", {-s, -s, s}}};
  all.resize(static_cast<size_t>(n));
  return all;
}

void LengthTest(const AcceptanceOptions& o,
                const ViewChain& chain,
                const Pose3& true_m,
                FinishResult* out) {
  const double radius = o.sphere_diameter_mm / 2;
  const int n = o.gauge_spheres;
  std::mt19937_64 rng(o.seed * 104729 + 3);
  const std::vector<Orientation> orientations = GaugeOrientations(o.length_orientations);
  for (size_t oi = 0; oi < orientations.size(); ++oi) {
    const Orientation& ori = orientations[oi];
    std::vector<Vec3> centres;
    centres.reserve(static_cast<size_t>(n));
    for (int k = 0; k < n; ++k)
      centres.push_back(kGaugeCentreMcs + (k - (n - 1) / 2.0) * o.gauge_pitch_mm * ori.direction);
    const sim::Scene scene = SpheresOnStems(centres, o.sphere_diameter_mm, out->finish.material);
    std::vector<ViewPlan> plans;
    for (size_t k = 0; k < centres.size(); ++k) {
      int attempts = 0;
      do {
        if (++attempts > kPlanAttempts)
          throw VerifyError(std::string("no clear view of a gauge sphere in orientation ") +
                            ori.name);
        plans.push_back(RandomPlan(rng, kGaugeStandoffMm));
        if (Unobstructed(plans.back(), centres, k, radius, *chain.calibrated)) break;
        plans.pop_back();
      } while (true);
    }
    std::vector<Vec3> measured(static_cast<size_t>(n)), with_true_m(static_cast<size_t>(n));
    std::vector<int> aside(static_cast<size_t>(n), 0);
    ForEachView(n, [&](int k) {
      const auto kk = static_cast<size_t>(k);
      Progress(o, out->finish.material + " gauge " + ori.name + " sphere " + std::to_string(k + 1) +
                      "/" + std::to_string(n));
      const View v = RenderView(chain, scene, centres[kk], radius, plans[kk], out->finish.exposure,
                                o.seed * 3000 + 100 * oi + kk);
      const Vec3 c = geometry::FitSphere(SpherePoints(v, radius, &aside[kk])).shape.center;
      measured[kk] = v.mcs_from_flange * chain.host_flange_from_probe * c;
      with_true_m[kk] = v.mcs_from_flange * true_m * c;
    });
    for (int a : aside) out->gauge_points_set_aside += a;
    for (int k = 1; k < n; ++k) {
      const auto kk = static_cast<size_t>(k);
      LengthError e;
      e.orientation = ori.name;
      e.length_mm = (centres[kk] - centres[0]).norm();
      e.error_um = ((measured[kk] - measured[0]).norm() - e.length_mm) * 1e3;
      e.error_true_m_um = ((with_true_m[kk] - with_true_m[0]).norm() - e.length_mm) * 1e3;
      out->lengths.push_back(e);
    }
  }
}

void Summarise(FinishResult* f) {
  double ss = 0.0;
  for (const ProbingView& v : f->views) {
    f->p_form_all_um = std::max(f->p_form_all_um, v.form_all_um);
    f->p_form_d95_um = std::max(f->p_form_d95_um, v.form_d95_um);
    f->p_form_1x25_um = std::max(f->p_form_1x25_um, v.form_1x25_um);
    if (std::abs(v.size_all_um) > std::abs(f->p_size_all_um)) f->p_size_all_um = v.size_all_um;
    if (std::abs(v.size_1x25_um) > std::abs(f->p_size_1x25_um)) f->p_size_1x25_um = v.size_1x25_um;
    ss += v.rms_um * v.rms_um;
  }
  if (!f->views.empty())
    f->dispersion_rms_um = std::sqrt(ss / static_cast<double>(f->views.size()));
  for (const LengthError& e : f->lengths) {
    if (std::abs(e.error_um) > std::abs(f->e_uni_um)) f->e_uni_um = e.error_um;
    if (std::abs(e.error_true_m_um) > std::abs(f->e_uni_true_m_um))
      f->e_uni_true_m_um = e.error_true_m_um;
  }
}

// Dorsch's limit [mm] at the point 120 mm down the camera's axis: theta the angle between the
// camera's and the projector's rays there, sin u_obs from the lens (CameraModel::ApertureSinAt).
double DorschLimitMm(const probe_fw::ProbeModel& m) {
  constexpr double kDepthMm = 120.0;
  if (!(m.camera.f_number > 0.0)) return 0.0;
  const Vec3 p(0, 0, kDepthMm);
  const Vec3 to_projector = (m.projector.Center() - p).normalized();
  const double sin_theta = to_projector.cross(-p.normalized()).norm();
  const double lambda_mm = m.laser.wavelength_nm * 1e-6;
  return m.noise.speckle_contrast * lambda_mm /
         (2 * M_PI * m.camera.ApertureSinAt(kDepthMm) * sin_theta);
}

Machine LoadMachine(const AcceptanceOptions& o) {
  Machine m;
  // Which of the two files is wrong, and its path: the parsers' messages name neither.
  try {
    m.as_built = sim::LoadAsBuilt(o.as_built_path);
  } catch (const base::InputError& e) {
    throw VerifyError("the as-built probe " + o.as_built_path + ": " + e.what());
  }
  try {
    m.calibrated = probe_fw::LoadProbeModel(o.calibrated_path);
  } catch (const base::InputError& e) {
    throw VerifyError("the calibrated model " + o.calibrated_path + ": " + e.what());
  }
  if (o.f_number) m.as_built.model.camera.f_number = *o.f_number;
  if (o.speckle_contrast) m.as_built.model.noise.speckle_contrast = *o.speckle_contrast;
  m.true_m_in_calibrated_frame =
      TrueMount() *
      sim::TrueFromModelFrame(m.as_built, m.calibrated, &kSphereWindow, &m.frame_rms_mm);
  return m;
}

}  // namespace

void AcceptanceOptions::Check() const {
  auto fail = [](const std::string& what) { throw VerifyError(what); };
  if (as_built_path.empty() || calibrated_path.empty())
    fail("the as-built probe and its calibrated model are both needed");
  if (f_number && !(*f_number >= 1.0 && *f_number <= 32.0)) fail("f-number must be in [1, 32]");
  if (speckle_contrast && !(*speckle_contrast >= 0.0 && *speckle_contrast <= 1.0))
    fail("speckle contrast must be in [0, 1]");
  if (finishes.empty()) fail("no finish to test");
  for (const Finish& f : finishes) {
    if (!(f.exposure > 0.0 && f.exposure <= 100.0)) fail("exposure must be in (0, 100]");
    try {
      sim::MakeNamedFinish(sim::MakeSphere(Vec3::Zero(), 1.0, 0.5), f.material);
    } catch (const sim::SceneError& e) {
      fail(e.what());
    }
  }
  if (!(sphere_diameter_mm >= 10.0 && sphere_diameter_mm <= 51.0))
    fail("sphere diameter must be in [10, 51] mm (ISO 10360-8's test spheres)");
  if (hand_eye_views < 6 || hand_eye_views > 24) fail("hand-eye views must be 6..24");
  if (probing_views < 1 || probing_views > 100) fail("probing views must be 1..100");
  if (length_orientations < 0 || length_orientations > 7) fail("orientations must be 0..7");
  if (gauge_spheres < 2 || gauge_spheres > 8) fail("gauge spheres must be 2..8");
  if (!(gauge_pitch_mm >= sphere_diameter_mm + 10.0 && gauge_pitch_mm <= 200.0))
    fail("gauge pitch must leave 10 mm between spheres and be at most 200 mm");
}

AcceptanceResult RunAcceptance(const AcceptanceOptions& options) {
  options.Check();
  const Machine machine = LoadMachine(options);
  AcceptanceResult res;
  res.calibration_frame_rms_um = machine.frame_rms_mm * 1e3;
  const auto& cam = machine.as_built.model.camera;
  res.f_number = cam.f_number;
  res.speckle_contrast = machine.as_built.model.noise.speckle_contrast;
  // The speckle grain: the Airy disc's diameter on the sensor, 2.44 lambda N / pitch.
  res.grain_px =
      2.44 * machine.as_built.model.laser.wavelength_nm * 1e-6 * cam.f_number / cam.pixel_pitch_mm;

  res.dorsch_limit_um = DorschLimitMm(machine.as_built.model) * 1e3;

  const calib::HandEyeResult he = CalibrateHandEye(options, machine);
  const Pose3& truth = machine.true_m_in_calibrated_frame;
  res.hand_eye_translation_um =
      (he.flange_from_probe.translation() - truth.translation()).norm() * 1e3;
  res.hand_eye_rotation_arcsec =
      Eigen::AngleAxisd(he.flange_from_probe.linear() * truth.linear().transpose()).angle() *
      kArcsecPerRad;
  res.hand_eye_point_rms_um = he.point_rms_mm * 1e3;

  const ViewChain chain{&machine.as_built, &machine.calibrated, TrueMount(), he.flange_from_probe};
  for (const Finish& f : options.finishes) {
    FinishResult fr;
    fr.finish = f;
    ProbingTest(options, chain, &fr);
    LengthTest(options, chain, truth, &fr);
    Summarise(&fr);
    res.finishes.push_back(std::move(fr));
  }
  return res;
}

}  // namespace mlp::verify
