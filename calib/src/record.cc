#include "mlp/calib/record.h"

#include "mlp/base/clock.h"
#include "mlp/base/files.h"
#include "mlp/base/json_fields.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <tuple>

namespace mlp::calib {
namespace {

namespace jf = base::json_fields;
namespace fs = std::filesystem;
using json = nlohmann::ordered_json;

constexpr const char* kFormat = "mlprobe-calibration/1";

json Vec(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

const char* KindName(RecordKind k) { return k == RecordKind::kHandEye ? "hand-eye" : "recheck"; }

void CheckSerial(const std::string& serial) {
  if (serial.empty() || serial.size() > 64 || serial.front() == '.' ||
      !std::all_of(serial.begin(), serial.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.';
      })) {
    throw RecordError("probe serial '" + serial +
                      "' must be 1-64 letters, digits, '-', '_' or '.' (it names a folder)");
  }
}

std::vector<OrientationDatum> Orientations(const Pose3& m,
                                           const std::vector<std::string>& ids,
                                           const std::vector<Pose3>& poses) {
  std::vector<OrientationDatum> out;
  for (size_t i = 0; i < poses.size(); ++i) {
    const Eigen::AngleAxisd aa(poses[i].linear());
    out.push_back({ids[i], aa.axis() * aa.angle(), poses[i].linear() * m.translation(),
                   poses[i].linear() * m.linear() * Vec3::UnitZ()});
  }
  return out;
}

}  // namespace

CalibrationRecord MakeRecord(const std::string& probe_serial,
                             const HandEyeResult& r,
                             const std::vector<SphereCapture>& captures,
                             double sphere_radius_mm) {
  CalibrationRecord rec;
  rec.probe_serial = probe_serial;
  rec.kind = RecordKind::kHandEye;
  rec.flange_from_probe = r.flange_from_probe;
  rec.covariance = r.covariance;
  rec.sphere_radius_mm = sphere_radius_mm;
  rec.sphere_centre_mcs = r.centre_mcs;
  rec.point_rms_mm = r.point_rms_mm;
  rec.points_used = r.points_used;
  rec.points_rejected = r.points_rejected;
  rec.centre_spread_rms_mm = r.centre_spread_rms_mm;
  std::vector<std::string> ids;
  std::vector<Pose3> poses;
  for (const auto& c : captures) ids.push_back(c.id), poses.push_back(c.mcs_from_flange);
  rec.orientations = Orientations(r.flange_from_probe, ids, poses);
  rec.notes = r.warnings;
  return rec;
}

CalibrationRecord MakeRecord(const std::string& probe_serial,
                             const BoardHandEyeResult& r,
                             const std::vector<RobotImage>& images) {
  CalibrationRecord rec;
  rec.probe_serial = probe_serial;
  rec.kind = RecordKind::kHandEye;
  rec.reference = Reference::kBoard;
  rec.flange_from_probe = r.flange_from_camera;  // the probe frame is the camera's (DESIGN.md)
  rec.covariance.topLeftCorner<6, 6>() = r.covariance;
  rec.base_from_board = r.base_from_board;
  rec.corner_rms_px = r.corner_rms_px;
  rec.corners_used = r.corners_used;
  rec.points_used = r.laser_points_used;
  rec.point_rms_mm = r.laser_sigma_mm;
  std::vector<std::string> ids;
  std::vector<Pose3> poses;
  for (const auto& im : images) ids.push_back(im.name), poses.push_back(im.base_from_flange);
  rec.orientations = Orientations(r.flange_from_camera, ids, poses);
  rec.notes = r.warnings;
  return rec;
}

CalibrationRecord MakeRecord(const CalibrationRecord& parent,
                             const RecheckResult& r,
                             const std::vector<RecheckCapture>& captures) {
  if (parent.reference != Reference::kSphere)
    throw RecordError("calibration " + parent.calibration_id +
                      " was measured against a board: a recheck needs the sphere");
  if (parent.kind != RecordKind::kHandEye)
    throw RecordError("a recheck corrects a full calibration, not another recheck (" +
                      parent.calibration_id + "): updates are never compounded");
  CalibrationRecord rec = parent;
  rec.kind = RecordKind::kRecheck;
  rec.parent_id = parent.calibration_id;
  rec.calibration_id.clear();
  rec.created_utc.clear();
  rec.flange_from_probe = r.flange_from_probe;
  rec.sphere_centre_mcs = r.centre_mcs;
  rec.point_rms_mm = r.residual_after_rms_mm;
  rec.points_used = rec.points_rejected = 0;
  rec.centre_spread_rms_mm = 0.0;
  // Seed 002: the correction rotated into every orientation of the original's table (its datum
  // recomputed with the corrected mount at that orientation's flange rotation), then the
  // orientations the recheck measured. The parent's record itself is left as it was.
  std::vector<std::string> ids;
  std::vector<Pose3> poses;
  for (const OrientationDatum& d : parent.orientations) {
    Pose3 flange = Pose3::Identity();
    const double angle = d.flange_rotation_vector_rad.norm();
    if (angle > 0)
      flange.linear() =
          Eigen::AngleAxisd(angle, d.flange_rotation_vector_rad / angle).toRotationMatrix();
    ids.push_back(d.capture_id), poses.push_back(flange);
  }
  for (const auto& c : captures)
    ids.push_back("recheck " + c.id), poses.push_back(c.mcs_from_flange);
  rec.orientations = Orientations(r.flange_from_probe, ids, poses);
  rec.notes = r.not_determined;
  rec.notes.push_back("the original's " + std::to_string(parent.orientations.size()) +
                      " orientations updated with the correction, " +
                      std::to_string(captures.size()) + " measured in the recheck");
  rec.offset_in_flange_mm = r.offset_in_flange_mm;
  rec.rotation_in_flange_rad = r.rotation_in_flange_rad;
  rec.centre_shift_mm = r.centre_shift_mm;
  return rec;
}

std::string ToJson(const CalibrationRecord& r) {
  json j;
  j["format"] = kFormat;
  j["calibration_id"] = r.calibration_id;
  j["probe_serial"] = r.probe_serial;
  j["kind"] = KindName(r.kind);
  j["created_utc"] = r.created_utc;
  j["sequence"] = r.sequence;
  j["parent_id"] = r.parent_id;
  j["flange_from_probe"] = jf::PoseToJson(r.flange_from_probe);
  json cov = json::array();
  for (int i = 0; i < 9; ++i) {
    json row = json::array();
    for (int k = 0; k < 9; ++k) row.push_back(r.covariance(i, k));
    cov.push_back(row);
  }
  j["covariance"] = {{"parameters", kHandEyeParameters}, {"matrix", cov}};
  if (r.reference == Reference::kSphere) {
    j["reference"] = "sphere";
    j["sphere"] = {{"radius_mm", r.sphere_radius_mm}, {"centre_mcs_mm", Vec(r.sphere_centre_mcs)}};
  } else {
    j["reference"] = "board";
    j["board"] = {{"base_from_board", jf::PoseToJson(r.base_from_board)},
                  {"corner_rms_px", r.corner_rms_px},
                  {"corners_used", r.corners_used}};
  }
  j["stats"] = {{"point_rms_mm", r.point_rms_mm},
                {"points_used", r.points_used},
                {"points_rejected", r.points_rejected},
                {"centre_spread_rms_mm", r.centre_spread_rms_mm}};
  json orientations = json::array();
  for (const auto& o : r.orientations) {
    orientations.push_back({{"capture_id", o.capture_id},
                            {"flange_rotation_vector_rad", Vec(o.flange_rotation_vector_rad)},
                            {"probe_origin_offset_mcs_mm", Vec(o.probe_origin_offset_mcs_mm)},
                            {"probe_axis_mcs", Vec(o.probe_axis_mcs)}});
  }
  j["orientations"] = orientations;
  j["notes"] = r.notes;
  if (r.kind == RecordKind::kRecheck) {
    j["change"] = {{"offset_in_flange_mm", Vec(r.offset_in_flange_mm)},
                   {"rotation_in_flange_rad", Vec(r.rotation_in_flange_rad)},
                   {"centre_shift_mm", Vec(r.centre_shift_mm)}};
  }
  return j.dump(2) + "\n";
}

namespace {

// "reference" is absent in records written before the board hand-eye: the sphere.
void ParseReference(const jf::json& j, CalibrationRecord* r) {
  const std::string ref =
      j.contains("reference") ? jf::Text<RecordError>(j, "reference", "record") : "sphere";
  if (ref != "sphere" && ref != "board")
    throw RecordError("record.reference must be \"sphere\" or \"board\"");
  if (ref == "sphere") {
    const auto& sphere = jf::Object<RecordError>(j, "sphere", "record");
    r->sphere_radius_mm = jf::Number<RecordError>(sphere, "radius_mm", "record.sphere");
    r->sphere_centre_mcs = jf::Vector3<RecordError>(sphere, "centre_mcs_mm", "record.sphere");
    return;
  }
  r->reference = Reference::kBoard;
  const auto& board = jf::Object<RecordError>(j, "board", "record");
  r->base_from_board = jf::Pose<RecordError>(
      jf::Object<RecordError>(board, "base_from_board", "record.board"), "record.board");
  r->corner_rms_px = jf::Number<RecordError>(board, "corner_rms_px", "record.board");
  r->corners_used = jf::Integer<RecordError>(board, "corners_used", "record.board");
}

}  // namespace

CalibrationRecord ParseRecord(const std::string& text) {
  const jf::json j = jf::ParseDocument<RecordError>(text, kFormat, "calibration record");
  CalibrationRecord r;
  r.calibration_id = jf::Text<RecordError>(j, "calibration_id", "record");
  r.probe_serial = jf::Text<RecordError>(j, "probe_serial", "record");
  const std::string kind = jf::Text<RecordError>(j, "kind", "record");
  if (kind != "hand-eye" && kind != "recheck")
    throw RecordError("record.kind must be \"hand-eye\" or \"recheck\"");
  r.kind = kind == "hand-eye" ? RecordKind::kHandEye : RecordKind::kRecheck;
  r.created_utc = jf::Text<RecordError>(j, "created_utc", "record");
  r.sequence = jf::Integer<RecordError>(j, "sequence", "record");
  r.parent_id = jf::Text<RecordError>(j, "parent_id", "record");
  r.flange_from_probe = jf::Pose<RecordError>(
      jf::Object<RecordError>(j, "flange_from_probe", "record"), "record.flange_from_probe");
  const auto& cov = jf::Object<RecordError>(j, "covariance", "record");
  if (!cov.contains("matrix") || !cov.at("matrix").is_array() || cov.at("matrix").size() != 9)
    throw RecordError("record.covariance.matrix must be 9 x 9");
  for (int i = 0; i < 9; ++i) {
    const auto& row = cov.at("matrix")[static_cast<size_t>(i)];
    if (!row.is_array() || row.size() != 9)
      throw RecordError("record.covariance.matrix must be 9 x 9");
    for (int k = 0; k < 9; ++k) {
      if (!row[static_cast<size_t>(k)].is_number())
        throw RecordError("record.covariance.matrix must hold numbers");
      r.covariance(i, k) = row[static_cast<size_t>(k)].get<double>();
    }
  }
  ParseReference(j, &r);
  const auto& stats = jf::Object<RecordError>(j, "stats", "record");
  r.point_rms_mm = jf::Number<RecordError>(stats, "point_rms_mm", "record.stats");
  r.points_used = jf::Integer<RecordError>(stats, "points_used", "record.stats");
  r.points_rejected = jf::Integer<RecordError>(stats, "points_rejected", "record.stats");
  r.centre_spread_rms_mm = jf::Number<RecordError>(stats, "centre_spread_rms_mm", "record.stats");
  if (j.contains("orientations") && j.at("orientations").is_array()) {
    for (const auto& o : j.at("orientations")) {
      r.orientations.push_back(
          {jf::Text<RecordError>(o, "capture_id", "record.orientations"),
           jf::Vector3<RecordError>(o, "flange_rotation_vector_rad", "record.orientations"),
           jf::Vector3<RecordError>(o, "probe_origin_offset_mcs_mm", "record.orientations"),
           jf::Vector3<RecordError>(o, "probe_axis_mcs", "record.orientations")});
    }
  }
  if (j.contains("notes") && j.at("notes").is_array()) {
    for (const auto& n : j.at("notes")) {
      if (n.is_string()) r.notes.push_back(n.get<std::string>());
    }
  }
  if (r.kind == RecordKind::kRecheck) {
    const auto& change = jf::Object<RecordError>(j, "change", "record");
    r.offset_in_flange_mm =
        jf::Vector3<RecordError>(change, "offset_in_flange_mm", "record.change");
    r.rotation_in_flange_rad =
        jf::Vector3<RecordError>(change, "rotation_in_flange_rad", "record.change");
    r.centre_shift_mm = jf::Vector3<RecordError>(change, "centre_shift_mm", "record.change");
  }
  return r;
}

std::string CalibrationStore::Save(CalibrationRecord record) const {
  CheckSerial(record.probe_serial);
  std::random_device rd;
  std::ostringstream id;
  id << record.probe_serial << "-" << base::UtcNow("%Y%m%dT%H%M%SZ", false) << "-" << std::hex
     << (rd() & 0xffffffu);
  record.calibration_id = id.str();
  record.created_utc = base::UtcNow("%Y-%m-%dT%H:%M:%S", true);
  const fs::path dir = fs::path(root_) / record.probe_serial;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw RecordError("cannot create " + dir.string() + ": " + ec.message());
  // Records made within one millisecond still list in the order they were made.
  const auto existing = List(record.probe_serial);
  record.sequence = existing.empty() ? 1 : existing.back().sequence + 1;
  const fs::path final_path = dir / (record.calibration_id + ".json");
  try {
    base::WriteFileAtomically(final_path.string(), ToJson(record), base::Replace::kNever);
  } catch (const base::FileError& e) {
    throw RecordError(std::string("cannot store the record: ") + e.what());
  }
  return record.calibration_id;
}

CalibrationRecord CalibrationStore::Load(const std::string& serial, const std::string& id) const {
  CheckSerial(serial);
  CheckSerial(id);
  const fs::path path = fs::path(root_) / serial / (id + ".json");
  if (!fs::exists(path))
    throw RecordError("no calibration " + id + " of probe " + serial + " in " + root_);
  const std::string text = base::ReadFileAs<RecordError>(path.string());
  try {
    return ParseRecord(text);
  } catch (const RecordError& e) {  // the same error, with the file the parser did not know
    throw RecordError(path.string() + ": " + e.what());
  }
}

std::vector<CalibrationRecord> CalibrationStore::List(const std::string& serial) const {
  CheckSerial(serial);
  std::vector<CalibrationRecord> out;
  const fs::path dir = fs::path(root_) / serial;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.front() == '.' || entry.path().extension() != ".json") continue;
    out.push_back(Load(serial, entry.path().stem().string()));
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) {
    return std::tie(a.sequence, a.created_utc) < std::tie(b.sequence, b.created_utc);
  });
  return out;
}

std::optional<CalibrationRecord> CalibrationStore::Latest(const std::string& serial,
                                                          std::optional<RecordKind> kind) const {
  const auto all = List(serial);
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    if (!kind || it->kind == *kind) return *it;
  }
  return std::nullopt;
}

}  // namespace mlp::calib
