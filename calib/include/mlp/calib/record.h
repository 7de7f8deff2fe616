#pragma once
/// @file Calibration records (`mlprobe-calibration/1`, docs/CALIBRATION.md) and the versioned
/// store that keeps them: one JSON file per calibration under <root>/<probe serial>/, written
/// atomically and never overwritten. A quick re-calibration is a new record whose parent is the
/// full calibration it was computed from; the original stays.

#include "mlp/base/input_error.h"
#include "mlp/calib/board_hand_eye.h"
#include "mlp/calib/hand_eye.h"
#include "mlp/calib/recheck.h"

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace mlp::calib {

class RecordError : public base::InputError {
 public:
  using base::InputError::InputError;
};

enum class RecordKind { kHandEye, kRecheck };

/// What the hand-eye was measured against: the reference sphere (hand_eye.h) or a fixed
/// chessboard with the laser on it (board_hand_eye.h). A recheck needs the sphere.
enum class Reference { kSphere, kBoard };

/// A flange orientation the calibration was measured at, and the probe's datum there: where the
/// probe's origin sits relative to the flange origin, and where its optical axis points, in MCS
/// directions (seed 002's datum data per orientation).
struct OrientationDatum {
  std::string capture_id;
  Vec3 flange_rotation_vector_rad = Vec3::Zero();
  Vec3 probe_origin_offset_mcs_mm = Vec3::Zero();
  Vec3 probe_axis_mcs = Vec3::UnitZ();
};

struct CalibrationRecord {
  std::string calibration_id;
  std::string probe_serial;
  RecordKind kind = RecordKind::kHandEye;
  std::string created_utc;  ///< ISO 8601 with milliseconds, e.g. 2026-11-21T21:30:00.125Z
  int sequence = 0;         ///< 1 for a probe's first record, then counting up
  std::string parent_id;    ///< recheck: the full calibration it corrects
  Reference reference = Reference::kSphere;
  Pose3 flange_from_probe = Pose3::Identity();
  /// kHandEye: the order of kHandEyeParameters; a board hand-eye fills the first 6 (X) only.
  Eigen::Matrix<double, 9, 9> covariance = Eigen::Matrix<double, 9, 9>::Zero();
  double sphere_radius_mm = 0.0;
  Vec3 sphere_centre_mcs = Vec3::Zero();
  /// Board only: the board's pose in the robot's base frame, and the joint fit's corners.
  Pose3 base_from_board = Pose3::Identity();
  double corner_rms_px = 0.0;
  int corners_used = 0;
  /// hand-eye: joint fit (board: the laser points' heights above the board, all of them);
  /// recheck: centre residual after.
  double point_rms_mm = 0.0;
  int points_used = 0, points_rejected = 0;
  double centre_spread_rms_mm = 0.0;
  std::vector<OrientationDatum> orientations;
  std::vector<std::string> notes;  ///< warnings and what was not determined
  // Recheck only: the change relative to the parent.
  Vec3 offset_in_flange_mm = Vec3::Zero();
  Vec3 rotation_in_flange_rad = Vec3::Zero();
  Vec3 centre_shift_mm = Vec3::Zero();
};

/// A new record from a hand-eye result (id and time filled in by the store).
CalibrationRecord MakeRecord(const std::string& probe_serial,
                             const HandEyeResult& result,
                             const std::vector<SphereCapture>& captures,
                             double sphere_radius_mm);
/// A new record from a board hand-eye; `images` are the views' names and flange poses (the
/// images of the findings the result was solved from).
CalibrationRecord MakeRecord(const std::string& probe_serial,
                             const BoardHandEyeResult& result,
                             const std::vector<RobotImage>& images);
/// A new record from a recheck against `parent` (a sphere hand-eye; throws RecordError else).
/// Its orientations: every one of the parent's, with its datum recomputed from the corrected
/// mount (seed 002: the correction rotated into every orientation), then the recheck's own
/// (ids "recheck <capture id>").
CalibrationRecord MakeRecord(const CalibrationRecord& parent,
                             const RecheckResult& result,
                             const std::vector<RecheckCapture>& captures);

std::string ToJson(const CalibrationRecord& record);
/// Throws RecordError naming the field.
CalibrationRecord ParseRecord(const std::string& json_text);

class CalibrationStore {
 public:
  explicit CalibrationStore(std::string root) : root_(std::move(root)) {}
  /// Gives the record an id and a time, writes it (temporary file, fsync, hard link: an existing
  /// file is never replaced) and returns the id. Throws RecordError.
  std::string Save(CalibrationRecord record) const;
  CalibrationRecord Load(const std::string& probe_serial, const std::string& calibration_id) const;
  /// Every record of a probe, oldest first.
  std::vector<CalibrationRecord> List(const std::string& probe_serial) const;
  /// The newest record of a probe (of `kind` if given), if any.
  std::optional<CalibrationRecord> Latest(const std::string& probe_serial,
                                          std::optional<RecordKind> kind = std::nullopt) const;

 private:
  std::string root_;
};

}  // namespace mlp::calib
