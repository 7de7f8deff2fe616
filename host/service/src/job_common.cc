#include "job_common.h"

#include "mlp/history/file_hash.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/json_fields.h"

#include <ctime>

namespace mlp::service {

namespace jf = probe_fw::json_fields;
using json = nlohmann::json;
using geometry::Vec3;

double Ms(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

double AgeHours(const std::string& utc) {
  std::tm t{};
  if (!strptime(utc.c_str(), "%Y-%m-%dT%H:%M:%S", &t)) return 1e9;  // unreadable: too old
  return std::difftime(std::time(nullptr), timegm(&t)) / 3600.0;
}

JobRun::JobRun(JobContext& c, const std::string& k, const json& request)
    : ctx(c),
      kind(k),
      calibration(
          calib::CalibrationStore(c.config.CalibrationDir()).Latest(c.machine.probe_serial)) {
  job = ctx.history.StartJob({ctx.machine.name, kind, ctx.machine.probe_serial,
                              calibration ? calibration->calibration_id : "", request});
  reply = {{"job_id", job}, {"machine", ctx.machine.name}};
}

const calib::CalibrationRecord& JobRun::Calibration() const {
  if (!calibration)
    throw JobInputError("probe " + ctx.machine.probe_serial +
                        " has no calibration: run `mlp calibrate hand-eye` first");
  return *calibration;
}

json JobRun::Finish(history::JobStatus status, bool ok) {
  reply["ok"] = ok;
  reply["status"] = history::ToString(status);
  ctx.history.FinishJob(job, status, reply, {{"total", Ms(started)}});
  return reply;
}

json JobRun::Fail(const std::exception& e) {
  reply["error"] = e.what();
  ctx.log("job " + std::to_string(job) + " (" + kind + " on " + ctx.machine.name +
          ") failed: " + e.what());
  return Finish(history::JobStatus::kFailed, false);
}

jobs::BoreNominal ParseBoreNominal(const json& n, const std::string& w) {
  jobs::BoreNominal b;
  b.top_centre_mcs = jf::Vector3<JobInputError>(n, "top_centre_mm", w);
  b.axis_mcs = n.contains("axis") ? jf::Vector3<JobInputError>(n, "axis", w) : Vec3::UnitZ();
  b.diameter_mm = jf::Number<JobInputError>(n, "diameter_mm", w);
  b.depth_mm = jf::Number<JobInputError>(n, "depth_mm", w);
  b.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", b.band_mm, w);
  return b;
}

Evidence LoadCaptures(JobContext& ctx,
                      const json& capture_jobs,
                      const geometry::Pose3& flange_from_probe,
                      std::int64_t job) {
  if (!capture_jobs.is_array() || capture_jobs.empty())
    throw JobInputError("captures must list the capture jobs to use");
  std::vector<Vec3> pts;
  Evidence e;
  for (const auto& c : capture_jobs) {
    if (!c.is_number_integer()) throw JobInputError("request.captures holds capture job ids");
    const json stored = ctx.history.ExportJob(c.get<std::int64_t>());
    if (stored.at("kind") != "capture" || stored.at("status") != "done" ||
        stored.at("machine") != ctx.machine.name || stored.at("captures").empty())
      throw JobInputError("job " + std::to_string(c.get<std::int64_t>()) +
                          " is not a finished capture on " + ctx.machine.name);
    const json& row = stored.at("captures").at(0);
    const std::string path = row.at("cloud_path");
    if (history::Sha256OfFile(path) != row.at("cloud_sha256"))
      throw JobInputError("the cloud " + path + " changed since it was captured (SHA-256)");
    const probe_fw::CloudFile f = probe_fw::ReadCloudPly(path);
    if (!f.meta.mcs_from_flange) throw JobInputError(path + " holds no flange pose");
    e.probe_serial = f.meta.probe_serial;
    geometry::Pose3 h = geometry::Pose3::Identity();
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 4; ++k) h.matrix()(i, k) = (*f.meta.mcs_from_flange)[4 * i + k];
    const geometry::Pose3 mcs_from_probe = h * flange_from_probe;
    for (size_t i = 0; i < f.quality.size(); ++i)
      pts.push_back(mcs_from_probe * Vec3(f.xyz[3 * i], f.xyz[3 * i + 1], f.xyz[3 * i + 2]));
    ctx.history.AddCapture(job, {row.at("capture_id"), row.at("pose"), path, row.at("cloud_sha256"),
                                 row.at("points")});
  }
  e.points_mcs.resize(3, static_cast<Eigen::Index>(pts.size()));
  for (size_t i = 0; i < pts.size(); ++i) e.points_mcs.col(static_cast<Eigen::Index>(i)) = pts[i];
  return e;
}

}  // namespace mlp::service
