#include "job_common.h"

#include "mlp/base/json_fields.h"
#include "mlp/geometry/datum.h"
#include "mlp/history/file_hash.h"
#include "mlp/probe_fw/cloud_file.h"
#include "mlp/service/adapters.h"

#include <algorithm>
#include <cctype>
#include <ctime>
#include <filesystem>
#include <set>
#include <sstream>
#include <variant>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace mlp::service {

namespace jf = base::json_fields;
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

json StoredRequest(const json& request) {
  const std::string text = base::json_fields::DumpText(request);
  if (text.size() <= kMaxStoredRequestBytes) return request;
  json stub = {{"stored", "size and SHA-256 only: the request's JSON text is over " +
                              std::to_string(kMaxStoredRequestBytes) + " bytes"},
               {"bytes", text.size()},
               {"sha256", history::Sha256OfText(text)}};
  for (const char* key : {"op", "machine", "request_id"})
    if (request.contains(key) && request.at(key).is_string()) stub[key] = request.at(key);
  return stub;
}

bool RepeatsStoredRequest(const json& request, const std::string& stored_text) {
  return base::json_fields::DumpText(StoredRequest(request)) == stored_text;
}

JobRun::JobRun(JobContext& c, const std::string& k, const json& request)
    : ctx(c),
      kind(k),
      calibration(
          calib::CalibrationStore(c.config.CalibrationDir()).Latest(c.machine.probe_serial)) {
  job = ctx.history.StartJob({ctx.machine.name, kind, ctx.machine.probe_serial,
                              calibration ? calibration->calibration_id : "",
                              StoredRequest(request), RequestId(request)});
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
  reply["host_ms"] = Ms(started);  // the stored clouds to the decision written
  try {
    ctx.history.FinishJob(job, status, reply, {{"total", reply["host_ms"]}});
  } catch (const std::exception& e) {
    // The job's outcome stands (what was written was written); the history could not take it
    // (a full disk, a removed file). Said in the reply and the log; the next start closes it.
    reply["history_error"] = e.what();
    ctx.log("job " + std::to_string(job) + " (" + kind + " on " + ctx.machine.name + ") ended " +
            history::ToString(status) + " but is not recorded: " + e.what());
  }
  return reply;
}

json JobRun::Fail(const std::exception& e) {
  reply["error"] = e.what();
  ctx.log("job " + std::to_string(job) + " (" + kind + " on " + ctx.machine.name +
          ") failed: " + e.what());
  return Finish(history::JobStatus::kFailed, false);
}

json JobRun::Refuse(const std::vector<std::string>& problems) {
  reply["problems"] = problems;
  reply["error"] = "nothing written: " + problems.front();
  return Finish(history::JobStatus::kRefused, false);
}

json JobRun::WriteAndFinish(const nc::NcResult& out) {
  reply["status"] = "done";  // if a stop comes during the write
  reply["files"] = WriteToController(ctx, job, out, reply, OffsetWriteRows(out));
  return Finish(history::JobStatus::kDone, true);
}

toolcam::ToolDescription ReadToolDescription(const JobContext& ctx,
                                             const std::string& file,
                                             const std::string& field) {
  constexpr std::size_t kMaxDescriptionBytes = 1u << 20;
  try {
    return toolcam::ParseTool(ReadDataFile(ctx.config.data_dir, file, field, kMaxDescriptionBytes));
  } catch (const toolcam::ToolInputError& e) {
    throw JobInputError(field + ": " + e.what());
  }
}

std::vector<std::string> WriteToController(JobContext& ctx,
                                           std::int64_t job,
                                           const nc::NcResult& out,
                                           const json& reply,
                                           std::vector<history::OffsetWriteRow> rows) {
  const ControllerConfig& c = ctx.machine.controller;
  for (auto& r : rows)
    r.adapter = ctx.machine.name + ":" + ControllerFile(c, ctx.machine.name, job);
  ctx.history.AddWriteIntents(job, rows, reply);
  // The gate checked the change (a radius change for D); the writer holds the same limit again.
  const double max_mm = ctx.machine.limits.max_offset_change_mm;
  WrittenFiles written;
  try {
    written = WriteResult(c, {max_mm, 2 * max_mm}, ctx.machine.name, job, out, reply);
  } catch (...) {
    // A write that failed is settled now as a restart would settle it, from what the controller
    // shows: left as "intent", a retry under the same request_id was answered with this
    // failure and never ran again.
    ctx.history.MarkWritesDone(
        job, WritesReachedController(c, ctx.machine.name, job, ToolChangesOf(rows)));
    throw;
  }
  ctx.history.MarkWritesDone(job);
  ctx.feed.OffsetsWritten(ctx.machine.name, job, rows);
  for (const std::string& w : written.warnings) ctx.log("job " + std::to_string(job) + ": " + w);
  return written.files;
}

std::string RequestId(const json& r) {
  if (!r.contains("request_id")) return "";
  std::string id = jf::Text<JobInputError>(r, "request_id", "request");
  const bool printable =
      std::all_of(id.begin(), id.end(), [](char c) { return c >= ' ' && c < 0x7f; });
  if (id.empty() || id.size() > 128 || !printable)
    throw JobInputError("request.request_id must be 1 to 128 printable ASCII characters");
  return id;
}

void CheckSafeName(const std::string& name, const std::string& field) {
  const bool ok =
      !name.empty() && name.size() <= 64 && name[0] != '.' &&
      std::all_of(name.begin(), name.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-';
      });
  if (!ok)
    throw JobInputError(field +
                        " must be 1 to 64 letters, digits, '.', '_' or '-', not starting with '.'");
}

std::string DataFolder(const std::string& data_dir,
                       const std::string& name,
                       const std::string& field) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path root = fs::weakly_canonical(data_dir, ec);
  const fs::path real = fs::weakly_canonical(fs::path(data_dir) / name, ec);
  const auto [in_root, in_real] = std::mismatch(root.begin(), root.end(), real.begin(), real.end());
  if (ec || in_root != root.end() || in_real == real.end() || !fs::is_directory(real, ec))
    throw JobInputError(field + ": " + name + " is not a folder inside the data folder " +
                        data_dir);
  return real.string();
}

std::vector<history::OffsetWriteRow> OffsetWriteRows(const nc::NcResult& out) {
  std::vector<history::OffsetWriteRow> rows;
  for (const auto& t : out.tools)
    rows.push_back(
        {"", "offset " + std::to_string(t.tool) + " " + nc::ToString(t.reg),
         t.incremental ? json() : json(t.before_mm),
         t.incremental ? json{{"change_mm", t.after_mm - t.before_mm}} : json(t.after_mm),
         "written", t});
  for (const auto& w : out.work)
    rows.push_back({"",
                    "work offset " + std::to_string(w.index),
                    json(),
                    {{"shift_mm", {w.after_mm[0], w.after_mm[1], w.after_mm[2]}}}});
  return rows;
}

std::vector<nc::ToolOffsetChange> ToolChangesOf(const std::vector<history::OffsetWriteRow>& rows) {
  std::vector<nc::ToolOffsetChange> out;
  for (const history::OffsetWriteRow& row : rows)
    if (row.tool && !row.tool->incremental) out.push_back(*row.tool);
  return out;
}

std::string ReadDataFile(const std::string& data_dir,
                         const std::string& name,
                         const std::string& field,
                         std::size_t max_bytes) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path root = fs::weakly_canonical(data_dir, ec);
  const fs::path real = fs::weakly_canonical(fs::path(data_dir) / name, ec);
  const auto [in_root, in_real] = std::mismatch(root.begin(), root.end(), real.begin(), real.end());
  if (ec || in_root != root.end() || in_real == real.end())
    throw JobInputError(field + ": " + name + " is not a file inside the data folder " + data_dir);
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it.
  const int fd = ::open(real.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw JobInputError(field + ": cannot read " + name);
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
    throw JobInputError(field + ": " + name + " is not a regular file");
  if (static_cast<std::size_t>(st.st_size) > max_bytes)
    throw JobInputError(field + ": " + name + " is " + std::to_string(st.st_size) +
                        " bytes; at most " + std::to_string(max_bytes) + " are read");
  std::string text(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t got = 0;
  while (got < text.size()) {
    const ssize_t n = ::read(fd, text.data() + got, text.size() - got);
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  text.resize(got);
  return text;
}

features::BoreNominal ParseBoreNominal(const json& n, const std::string& w) {
  features::BoreNominal b;
  b.top_centre_mcs = jf::Vector3<JobInputError>(n, "top_centre_mm", w);
  b.axis_mcs = n.contains("axis") ? jf::Vector3<JobInputError>(n, "axis", w) : Vec3::UnitZ();
  b.diameter_mm = jf::Number<JobInputError>(n, "diameter_mm", w);
  b.depth_mm = jf::Number<JobInputError>(n, "depth_mm", w);
  b.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", b.band_mm, w);
  return b;
}

features::PlaneNominal ParsePlaneNominal(const json& n, const std::string& w) {
  features::PlaneNominal p;
  p.point_mcs = jf::Vector3<JobInputError>(n, "point_mm", w);
  p.normal_mcs = jf::Vector3<JobInputError>(n, "normal", w);
  p.band_mm = jf::NumberOr<JobInputError>(n, "band_mm", p.band_mm, w);
  p.within_mm = jf::NumberOr<JobInputError>(n, "within_mm", p.within_mm, w);
  return p;
}

// A capture by job id, or by the name the macro gave it: its newest capture of that name on
// this machine, which must have succeeded and be recent (a failed or missing capture never
// lets an older one of the same name stand in).
std::int64_t CaptureJobId(JobContext& ctx, const json& c) {
  if (c.is_number_integer()) return c.get<std::int64_t>();
  if (!c.is_string())
    throw JobInputError("request.captures holds capture job ids or capture names");
  const std::string name = c.get<std::string>();
  const auto latest = ctx.history.LatestCapture(ctx.machine.name, name);
  if (!latest) throw JobInputError("no capture named \"" + name + "\" on " + ctx.machine.name);
  const std::string what =
      "the latest capture \"" + name + "\" (job " + std::to_string(latest->id) + ")";
  if (latest->status != history::JobStatus::kDone)
    throw JobInputError(what + " " + history::ToString(latest->status) + ": take it again");
  if (AgeHours(latest->started_utc) * 3600 > kNamedCaptureMaxAgeS)
    throw JobInputError(what + " is older than " + std::to_string(kNamedCaptureMaxAgeS / 60) +
                        " minutes: take it again");
  return latest->id;
}

// The capture rows a job will read, checked before any cloud is: each a finished capture on
// this machine, none named twice (a 7 KB request naming one capture 1,500 times made the host
// read it 1,500 times and peak at 7.7 GB, issue 48), their points within the job's budget.
std::vector<history::CaptureRow> CaptureRows(JobContext& ctx, const json& capture_jobs) {
  if (!capture_jobs.is_array() || capture_jobs.empty())
    throw JobInputError("captures must list the capture jobs to use");
  if (capture_jobs.size() > kMaxCapturesPerJob)
    throw JobInputError("captures lists " + std::to_string(capture_jobs.size()) +
                        " captures; a job takes at most " + std::to_string(kMaxCapturesPerJob));
  std::set<std::int64_t> seen;
  std::int64_t points = 0;
  std::vector<history::CaptureRow> rows;
  for (const auto& c : capture_jobs) {
    const std::int64_t id = CaptureJobId(ctx, c);
    if (!seen.insert(id).second)
      throw JobInputError("captures names capture job " + std::to_string(id) +
                          " twice: each capture counts once");
    history::JobCaptures stored = ctx.history.CapturesOf(id);
    if (stored.job.kind != "capture" || stored.job.status != history::JobStatus::kDone ||
        stored.job.machine != ctx.machine.name || stored.captures.empty())
      throw JobInputError("job " + std::to_string(id) + " is not a finished capture on " +
                          ctx.machine.name);
    rows.push_back(std::move(stored.captures.front()));
    points += rows.back().points;
    if (points > kMaxJobPoints)
      throw JobInputError("the captures hold over " + std::to_string(kMaxJobPoints) +
                          " points together; a job takes at most that many");
  }
  return rows;
}

std::vector<StoredCapture> LoadStoredCaptures(JobContext& ctx,
                                              const json& capture_jobs,
                                              std::int64_t job) {
  std::vector<StoredCapture> out;
  for (const history::CaptureRow& row : CaptureRows(ctx, capture_jobs)) {
    if (history::Sha256OfFile(row.cloud_path) != row.cloud_sha256)
      throw JobInputError("the cloud " + row.cloud_path +
                          " changed since it was captured (SHA-256)");
    const probe_fw::CloudFile f = probe_fw::ReadCloudPly(row.cloud_path);
    if (!f.meta.mcs_from_flange) throw JobInputError(row.cloud_path + " holds no flange pose");
    StoredCapture s;
    s.id = row.capture_id;
    s.probe_serial = f.meta.probe_serial;
    s.mcs_from_flange = *f.meta.mcs_from_flange;
    s.edge = f.meta.edge;
    s.pose = row.pose;
    s.points_in_probe = Eigen::Map<const Eigen::Matrix3Xd>(
        f.xyz.data(), 3, static_cast<Eigen::Index>(f.quality.size()));
    ctx.history.AddCapture(job, row);  // the job names the capture it read
    out.push_back(std::move(s));
  }
  return out;
}

bool FittedKinematics(const json& r) {
  if (!r.contains("kinematics")) return false;
  const std::string k = jf::Text<JobInputError>(r, "kinematics", "request");
  if (k != "controller" && k != "fitted")
    throw JobInputError("request.kinematics is \"controller\" or \"fitted\", not \"" + k + "\"");
  return k == "fitted";
}

Evidence LoadCaptures(JobContext& ctx,
                      const json& capture_jobs,
                      const geometry::Pose3& flange_from_probe,
                      std::int64_t job,
                      bool fitted_kinematics) {
  Evidence e;
  std::vector<geometry::Points3> parts;
  Eigen::Index n = 0;
  std::vector<StoredCapture> stored = LoadStoredCaptures(ctx, capture_jobs, job);
  if (fitted_kinematics) UseFittedKinematics(ctx, &stored);
  for (StoredCapture& s : stored) {
    e.probe_serial = s.probe_serial;
    n += s.points_in_probe.cols();
    const geometry::Pose3 mcs_from_probe = s.mcs_from_flange * flange_from_probe;
    parts.push_back(geometry::TransformPoints(mcs_from_probe, s.points_in_probe));
    if (s.edge) e.edges.push_back(features::EdgeViewInMcs(*s.edge, mcs_from_probe, s.id));
  }
  e.points_mcs.resize(3, n);
  Eigen::Index at = 0;
  for (const auto& p : parts) e.points_mcs.middleCols(at, p.cols()) = p, at += p.cols();
  return e;
}

namespace {
// A reading's value as JSON: numbers as they are, a vector as [x, y, z], a group as an object.
json ValueJson(double v) { return v; }
json ValueJson(std::int64_t v) { return v; }
json ValueJson(const std::string& v) { return v; }
json ValueJson(const geometry::Vec3& v) { return JsonVec(v); }
json ValueJson(const std::vector<std::string>& v) { return v; }
json ValueJson(const jobs::Readings& v) { return ReadingsJson(v); }
template <class T>
json ValueJson(const std::vector<T>& list) {
  json out = json::array();
  for (const T& item : list) out.push_back(ValueJson(item));
  return out;
}
}  // namespace

json ReadingsJson(const jobs::Readings& readings) {
  json out = json::object();
  for (const jobs::Reading& r : readings)
    out[r.name] = std::visit([](const auto& v) { return ValueJson(v); }, r.value);
  return out;
}

}  // namespace mlp::service
