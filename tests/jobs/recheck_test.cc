// The recheck job in-process (issue 53): the probe re-seated after a disturbance of known size
// (calib's synthetic sphere captures, tests/calib/hand_eye_fixture.h), rechecked against the
// full calibration as the service's recheck job does.

#include "mlp/jobs/recheck.h"

#include "../calib/hand_eye_fixture.h"
#include <gtest/gtest.h>

namespace mlp::jobs {
namespace {

namespace ct = calib::testing;
using geometry::Vec3;

constexpr double kOffsetTolMm = 0.002;  // issue 5: disturbances recovered within 2 um
constexpr double kNoiseMm = 0.002;

calib::CalibrationRecord Original(const ct::Truth& truth) {
  calib::CalibrationRecord r;
  r.calibration_id = "full-1";
  r.flange_from_probe = truth.flange_from_probe;
  r.sphere_centre_mcs = truth.centre_mcs;
  return r;
}

// The sphere seen at `orientations` spindle orientations by the probe as it now sits.
RecheckInputs Inputs(const ct::Truth& now, int orientations, unsigned seed) {
  RecheckInputs in;
  in.sphere_radius_mm = now.radius_mm;
  const auto poses = ct::MakePoses(ct::DefaultTruth(), ct::PoseSet::kFiveAxis, orientations);
  for (const auto& c : ct::SyntheticCaps(now, poses, kNoiseMm, 0.01, 3000, seed))
    in.captures.push_back({c.id, c.mcs_from_flange, c.points_in_probe});
  return in;
}

TEST(RecheckJob, AMountShiftedBy80MicrometresIsFoundFromTheSphere) {
  const ct::Truth truth = ct::DefaultTruth();
  ct::Truth now = truth;
  now.flange_from_probe.translation() += Vec3(0.05, -0.03, 0.08);
  const RecheckOutcome o = AssessRecheck(Inputs(now, 1, 1), Original(truth));  // the offset alone
  EXPECT_EQ(o.artefact, "sphere");
  EXPECT_EQ(o.sphere_centre_from, "the full calibration");
  EXPECT_FALSE(o.result.full_calibration_required) << o.result.reason;
  EXPECT_LT((o.result.flange_from_probe.translation() - now.flange_from_probe.translation()).norm(),
            kOffsetTolMm);
}

TEST(RecheckJob, ACrashOfAMillimetreAsksForAFullCalibration) {
  const ct::Truth truth = ct::DefaultTruth();
  ct::Truth crashed = truth;
  crashed.flange_from_probe.translation() += Vec3(0.8, 0.0, 0.0);
  const RecheckOutcome o = AssessRecheck(Inputs(crashed, 3, 6), Original(truth));
  EXPECT_TRUE(o.result.full_calibration_required);
  EXPECT_NE(o.result.reason.find("mount moved"), std::string::npos) << o.result.reason;
}

TEST(RecheckJob, ASphereCentreFromAnotherProbeIsTheReference) {
  const ct::Truth truth = ct::DefaultTruth();
  ct::Truth moved = truth;  // the sphere re-mounted 0.3 mm away, found by a touch probe
  moved.centre_mcs += Vec3(0.3, 0.0, 0.0);
  RecheckInputs in = Inputs(moved, 1, 10);
  in.sphere_centre_mcs = moved.centre_mcs;
  const RecheckOutcome o = AssessRecheck(in, Original(truth));
  EXPECT_EQ(o.sphere_centre_from, "the request (another probe)");
  EXPECT_FALSE(o.result.full_calibration_required) << o.result.reason;
  EXPECT_LT(
      (o.result.flange_from_probe.translation() - truth.flange_from_probe.translation()).norm(),
      kOffsetTolMm);  // the mount did not move
}

}  // namespace
}  // namespace mlp::jobs
