#include "measure_job.h"

#include "mlp/calib/record.h"
#include "mlp/history/file_hash.h"
#include "mlp/jobs/decision.h"
#include "mlp/jobs/feature.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/probe_fw/json_fields.h"
#include "mlp/service/adapters.h"

#include <chrono>
#include <ctime>

namespace mlp::service {
namespace {

namespace jf = probe_fw::json_fields;
using json = nlohmann::json;
using geometry::Vec3;
using Clock = std::chrono::steady_clock;

class JobInputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

double Ms(Clock::time_point since) {
  return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

// Hours since an ISO 8601 UTC time "YYYY-MM-DDTHH:MM:SS.mmmZ".
double AgeHours(const std::string& utc) {
  std::tm t{};
  if (!strptime(utc.c_str(), "%Y-%m-%dT%H:%M:%S", &t)) return 1e9;  // unreadable: too old
  return std::difftime(std::time(nullptr), timegm(&t)) / 3600.0;
}

nc::ToolRegister RegisterOf(const std::string& s) {
  if (s == "length_geometry") return nc::ToolRegister::kLengthGeometry;
  if (s == "length_wear") return nc::ToolRegister::kLengthWear;
  if (s == "radius_geometry") return nc::ToolRegister::kRadiusGeometry;
  if (s == "radius_wear") return nc::ToolRegister::kRadiusWear;
  throw JobInputError(
      "update.register must be length_geometry, length_wear, radius_geometry "
      "or radius_wear, not \"" +
      s + "\"");
}

jobs::BoreNominal ParseBore(const json& r) {
  const json& n = jf::Object<JobInputError>(r, "nominal", "request");
  jobs::BoreNominal b;
  b.top_centre_mcs = jf::Vector3<JobInputError>(n, "top_centre_mm", "request.nominal");
  b.axis_mcs =
      n.contains("axis") ? jf::Vector3<JobInputError>(n, "axis", "request.nominal") : Vec3::UnitZ();
  b.diameter_mm = jf::Number<JobInputError>(n, "diameter_mm", "request.nominal");
  b.depth_mm = jf::Number<JobInputError>(n, "depth_mm", "request.nominal");
  b.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", b.band_mm, "request.nominal");
  return b;
}

jobs::Feedback ParseUpdate(const json& r, double change_per_error) {
  jobs::Feedback f;
  f.change_per_error = change_per_error;
  if (!r.contains("update")) return f;  // report only
  const json& u = jf::Object<JobInputError>(r, "update", "request");
  const std::string w = "request.update";
  f.offset_number = jf::Integer<JobInputError>(u, "offset", w);
  f.reg = RegisterOf(jf::Text<JobInputError>(u, "register", w));
  f.percent = jf::NumberOr<JobInputError>(u, "percent", f.percent, w);
  f.null_band_mm = jf::NumberOr<JobInputError>(u, "null_band_mm", f.null_band_mm, w);
  f.upper_limit_mm = jf::NumberOr<JobInputError>(u, "upper_limit_mm", f.upper_limit_mm, w);
  f.experience_mm = jf::NumberOr<JobInputError>(u, "experience_mm", f.experience_mm, w);
  return f;
}

struct Evidence {
  geometry::Points3 points_mcs;
  std::string probe_serial;
};

// The stored captures of earlier capture jobs, checked against their recorded SHA-256, mapped
// into the machine frame with H (from the file) and M (the calibration).
Evidence LoadCaptures(JobContext& ctx,
                      const json& r,
                      const geometry::Pose3& flange_from_probe,
                      std::int64_t job) {
  if (!r.contains("captures") || !r.at("captures").is_array() || r.at("captures").empty())
    throw JobInputError("request.captures must list the capture jobs to use");
  std::vector<Vec3> pts;
  Evidence e;
  for (const auto& c : r.at("captures")) {
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

}  // namespace

json RunMeasureJob(JobContext& ctx, const json& r) {
  const auto t0 = Clock::now();
  const MachineConfig& m = ctx.machine;
  const calib::CalibrationStore store(ctx.config.CalibrationDir());
  const auto cal = store.Latest(m.probe_serial);
  const std::int64_t job =
      ctx.history.StartJob({m.name, "measure", m.probe_serial, cal ? cal->calibration_id : "", r});
  json reply = {{"job_id", job}, {"machine", m.name}};
  const auto finish = [&](history::JobStatus s, bool ok) {
    reply["ok"] = ok;
    reply["status"] = history::ToString(s);
    ctx.history.FinishJob(job, s, reply, {{"total", Ms(t0)}});
    return reply;
  };
  try {
    const std::string feature = jf::Text<JobInputError>(r, "feature", "request");
    if (feature != "bore") throw JobInputError("feature \"" + feature + "\" is not measured yet");
    if (!cal)
      throw JobInputError("probe " + m.probe_serial +
                          " has no calibration: run "
                          "`mlp calibrate hand-eye` first");
    const jobs::BoreNominal nominal = ParseBore(r);
    const Evidence ev = LoadCaptures(ctx, r, cal->flange_from_probe, job);
    const jobs::BoreMeasurement bore = jobs::MeasureBore(ev.points_mcs, nominal);
    const bool mic = r.value("size", std::string("ls")) == "mic";
    const double size = mic ? bore.diameter_mic_mm : bore.diameter_mm;
    const json& tol = jf::Object<JobInputError>(r, "tolerance", "request");
    const jobs::SizeSpec spec{nominal.diameter_mm,
                              jf::Number<JobInputError>(tol, "upper_mm", "request.tolerance"),
                              jf::Number<JobInputError>(tol, "lower_mm", "request.tolerance")};
    // A bore's diameter onto a radius offset: half the error (jobs::Feedback).
    const jobs::Feedback fb = ParseUpdate(r, 0.5);
    const jobs::SizeDecision d = jobs::DecideSize(size, spec, fb);
    const Vec3& c = bore.top_centre_mcs;
    reply.update({{"feature", "bore"},
                  {"calibration_id", cal->calibration_id},
                  {"diameter_mm", bore.diameter_mm},
                  {"diameter_mic_mm", bore.diameter_mic_mm},
                  {"size_mm", size},
                  {"centre_mm", {c.x(), c.y(), c.z()}},
                  {"rms_mm", bore.rms_mm},
                  {"points", bore.points},
                  {"arc_span_deg", bore.arc_span_deg},
                  {"error_mm", d.error_mm},
                  {"verdict", jobs::ToString(d.verdict)},
                  {"reason", d.reason},
                  {"offset_change_mm", d.offset_change_mm},
                  {"time_utc", history::UtcNow()}});
    ctx.history.AddResult(job, {"bore",
                                reply,
                                {{"verdict", jobs::ToString(d.verdict)},
                                 {"error_mm", d.error_mm},
                                 {"offset_change_mm", d.offset_change_mm},
                                 {"reason", d.reason}}});
    jobs::FitEvidence fe;
    fe.points = bore.points;
    fe.arc_span_deg = bore.arc_span_deg;
    fe.rms_mm = bore.rms_mm;
    fe.calibration_probe = cal->probe_serial;
    fe.job_probe = ev.probe_serial;
    fe.calibration_age_h = AgeHours(cal->created_utc);
    if (d.update) fe.offset_changes_mm = {d.offset_change_mm};
    const auto problems = jobs::PlausibilityProblems(fe, m.limits);
    if (!problems.empty()) {
      reply["problems"] = problems;
      reply["error"] = "nothing written: " + problems.front();
      return finish(history::JobStatus::kRefused, false);
    }
    nc::NcResult out;
    out.header =
        "mlprobe job " + std::to_string(job) + ": bore " + reply["verdict"].get<std::string>();
    out.named = {{"status", d.verdict == jobs::Verdict::kInTolerance ? 0.0 : 1.0},
                 {"diameter", size},
                 {"error", d.error_mm}};
    if (m.controller.kind != ControllerConfig::Kind::kLinuxCnc) out.named.clear();
    if (d.update) {
      std::string note;
      const nc::ToolOffsetChange t =
          ResolveToolChange(m.controller, fb.offset_number, fb.reg, d.offset_change_mm, &note);
      out.tools.push_back(t);
      reply["update"] = {{"offset", t.tool},
                         {"register", nc::ToString(t.reg)},
                         {"before_mm", t.incremental ? json() : json(t.before_mm)},
                         {"after_mm", t.incremental ? json() : json(t.after_mm)},
                         {"change_mm", d.offset_change_mm}};
      if (!note.empty()) reply["update"]["note"] = note;
    }
    const bool alarm = d.verdict == jobs::Verdict::kUpperLimitExceeded;
    if (alarm) reply["alarm"] = d.reason;
    reply["files"] = WriteResult(m.controller, m.name, job, out, reply);
    for (const auto& t : out.tools)
      ctx.history.AddOffsetWrite(
          job, {m.name + ":" + reply["files"].at(0).get<std::string>(),
                "offset " + std::to_string(t.tool) + " " + nc::ToString(t.reg),
                t.incremental ? json() : json(t.before_mm),
                t.incremental ? json{{"change_mm", t.after_mm - t.before_mm}} : json(t.after_mm)});
    return finish(d.verdict == jobs::Verdict::kInTolerance ? history::JobStatus::kInTolerance
                                                           : history::JobStatus::kOutOfTolerance,
                  true);
  } catch (const std::exception& e) {
    reply["error"] = e.what();
    ctx.log("job " + std::to_string(job) + " (measure on " + m.name + ") failed: " + e.what());
    return finish(history::JobStatus::kFailed, false);
  }
}

}  // namespace mlp::service
