// Calibration records: a round trip through the store, never overwritten, a recheck refers to
// the full calibration (never to another recheck), bad files are typed errors.

#include "mlp/calib/record.h"

#include <filesystem>
#include <fstream>

#include "hand_eye_fixture.h"
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace mlp::calib {
namespace {

namespace fs = std::filesystem;

fs::path FreshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("mlp_record_test_" + name);
  fs::remove_all(dir);
  return dir;
}

HandEyeResult SomeResult() {
  const testing::Truth truth = testing::DefaultTruth();
  HandEyeResult r;
  r.flange_from_probe = truth.flange_from_probe;
  r.centre_mcs = truth.centre_mcs;
  r.point_rms_mm = 0.0019;
  for (int i = 0; i < 9; ++i) r.covariance(i, i) = 1e-8 * (i + 1);
  r.covariance(3, 4) = r.covariance(4, 3) = 2e-9;
  r.warnings = {"weakly determined: nothing"};
  return r;
}

std::vector<SphereCapture> SomeCaptures() {
  const testing::Truth truth = testing::DefaultTruth();
  return testing::SyntheticCaps(truth, testing::MakePoses(truth, testing::PoseSet::kFiveAxis, 3),
                                0.002, 0.0, 30, 1);
}

TEST(CalibrationStore, RecordsRoundTripAndAreKeptInOrder) {
  const CalibrationStore store(FreshDir("round_trip").string());
  const auto captures = SomeCaptures();
  const CalibrationRecord rec = MakeRecord("MLP-REF-0001", SomeResult(), captures, 12.7);
  const std::string id1 = store.Save(rec);
  const std::string id2 = store.Save(rec);
  EXPECT_NE(id1, id2);
  const CalibrationRecord back = store.Load("MLP-REF-0001", id1);
  EXPECT_TRUE(back.flange_from_probe.isApprox(rec.flange_from_probe, 1e-15));
  EXPECT_EQ(back.covariance, rec.covariance);
  EXPECT_EQ(back.sphere_centre_mcs, rec.sphere_centre_mcs);
  ASSERT_EQ(back.orientations.size(), 3u);
  EXPECT_TRUE(back.orientations[1].probe_axis_mcs.isApprox(rec.orientations[1].probe_axis_mcs));
  EXPECT_EQ(back.notes, rec.notes);
  const auto all = store.List("MLP-REF-0001");
  ASSERT_EQ(all.size(), 2u);
  EXPECT_EQ(all[0].calibration_id, id1);
  EXPECT_EQ(store.Latest("MLP-REF-0001")->calibration_id, id2);
  EXPECT_FALSE(store.Latest("OTHER").has_value());
}

TEST(CalibrationStore, RecheckKeepsTheOriginalAndNeverCompounds) {
  const CalibrationStore store(FreshDir("recheck").string());
  const auto captures = SomeCaptures();
  CalibrationRecord full = MakeRecord("P1", SomeResult(), captures, 12.7);
  full.calibration_id = store.Save(full);
  RecheckResult change;
  change.flange_from_probe = full.flange_from_probe;
  change.flange_from_probe.translation() += Vec3(0.01, 0, 0);
  change.offset_in_flange_mm = Vec3(0.01, 0, 0);
  change.centre_mcs = full.sphere_centre_mcs;
  std::vector<RecheckCapture> rc{{"r1", captures[0].mcs_from_flange, captures[0].points_in_probe}};
  CalibrationRecord recheck = MakeRecord(full, change, rc);
  recheck.calibration_id = store.Save(recheck);
  EXPECT_EQ(store.Load("P1", recheck.calibration_id).parent_id, full.calibration_id);
  EXPECT_EQ(store.Latest("P1", RecordKind::kHandEye)->calibration_id, full.calibration_id);
  EXPECT_EQ(store.Latest("P1")->kind, RecordKind::kRecheck);
  EXPECT_EQ(store.List("P1").size(), 2u);                      // the original is still there
  EXPECT_THROW(MakeRecord(recheck, change, rc), RecordError);  // no recheck of a recheck
  // The original's per-orientation table carried forward, each datum with the corrected mount
  // at its own flange orientation, then the recheck's orientation.
  const CalibrationRecord back = store.Load("P1", recheck.calibration_id);
  ASSERT_EQ(back.orientations.size(), full.orientations.size() + 1);
  constexpr double kExactMm = 1e-12;
  for (size_t i = 0; i < full.orientations.size(); ++i) {
    const OrientationDatum& before = full.orientations[i];
    const OrientationDatum& after = back.orientations[i];
    EXPECT_EQ(after.capture_id, before.capture_id);
    const Eigen::Matrix3d flange = captures[i].mcs_from_flange.linear();
    EXPECT_LT((after.probe_origin_offset_mcs_mm - before.probe_origin_offset_mcs_mm -
               flange * Vec3(0.01, 0, 0))
                  .norm(),
              kExactMm);
    EXPECT_LT((after.probe_axis_mcs - before.probe_axis_mcs).norm(), kExactMm);  // no rotation
  }
  EXPECT_EQ(back.orientations.back().capture_id, "recheck r1");
  EXPECT_EQ(store.Load("P1", full.calibration_id).orientations.size(), full.orientations.size());
}

// A hand-eye measured against a board: its own fields round-trip, the sphere's are absent, and a
// recheck (which needs the sphere) refuses it as a parent.
TEST(CalibrationStore, BoardHandEyeRecordsRoundTripAndAreNoRecheckParent) {
  const CalibrationStore store(FreshDir("board").string());
  BoardHandEyeResult r;
  r.flange_from_camera = testing::DefaultTruth().flange_from_probe;
  r.base_from_board.translation() = Vec3(400, -20, 3);
  for (int i = 0; i < 6; ++i) r.covariance(i, i) = 1e-6 * (i + 1);
  r.corner_rms_px = 2.97, r.corners_used = 864, r.laser_points_used = 9000;
  r.laser_sigma_mm = 0.298;
  RobotImage im{"im0", "im0.png", Pose3::Identity()};
  const CalibrationRecord rec = MakeRecord("BLASER-1", r, {im});
  const CalibrationRecord back = store.Load("BLASER-1", store.Save(rec));
  EXPECT_EQ(back.reference, Reference::kBoard);
  EXPECT_TRUE(back.flange_from_probe.isApprox(r.flange_from_camera, 1e-15));
  EXPECT_TRUE(back.base_from_board.isApprox(r.base_from_board, 1e-15));
  EXPECT_TRUE((back.covariance.topLeftCorner<6, 6>() == r.covariance));
  EXPECT_TRUE((back.covariance.bottomRightCorner<3, 3>().isZero(0.0)));
  EXPECT_EQ(back.corners_used, 864);
  EXPECT_DOUBLE_EQ(back.point_rms_mm, 0.298);
  EXPECT_EQ(back.orientations.size(), 1u);
  const std::string text = ToJson(back);
  EXPECT_EQ(text.find("\"sphere\""), std::string::npos);
  EXPECT_THROW(MakeRecord(back, RecheckResult{}, {}), RecordError);
  // Records written before the board hand-eye (no "reference") read as sphere records.
  const CalibrationRecord sphere = MakeRecord("P1", SomeResult(), SomeCaptures(), 12.7);
  nlohmann::json old = nlohmann::json::parse(ToJson(sphere));
  old.erase("reference");
  EXPECT_EQ(ParseRecord(old.dump()).reference, Reference::kSphere);
}

TEST(CalibrationStore, BadSerialsAndFilesAreTypedErrors) {
  const fs::path dir = FreshDir("bad");
  const CalibrationStore store(dir.string());
  CalibrationRecord rec = MakeRecord("../escape", SomeResult(), SomeCaptures(), 12.7);
  EXPECT_THROW(store.Save(rec), RecordError);
  EXPECT_FALSE(fs::exists(dir.parent_path() / "escape"));
  EXPECT_THROW(store.Load("P1", "nope"), RecordError);
  fs::create_directories(dir / "P2");
  std::ofstream(dir / "P2" / "broken.json") << "{\"format\": \"mlprobe-calibration/1\"}";
  EXPECT_THROW(store.List("P2"), RecordError);
  EXPECT_THROW(ParseRecord("not json"), RecordError);
  EXPECT_THROW(ParseRecord("{\"format\": \"mlprobe-calibration/9\"}"), RecordError);
}

}  // namespace
}  // namespace mlp::calib
