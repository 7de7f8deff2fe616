#include "mlp/service/adapters.h"

#include "mlp/base/csv.h"
#include "mlp/base/files.h"
#include "mlp/nc/tool_table.h"
#include "mlp/nc/tool_table_update.h"
#include "mlp/service/request_json.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace mlp::service {
namespace {

namespace fs = std::filesystem;

// One CSV line per job for SPC, appended whole and durably (base::AppendRecord).
void AppendCsv(const fs::path& path, const nlohmann::json& r) {
  std::ostringstream line;
  line << r.value("job_id", 0) << "," << base::CsvField(r.value("machine", "")) << ","
       << base::CsvField(r.value("feature", "")) << "," << r.value("status", "") << ","
       << r.value("size_mm", 0.0) << "," << r.value("error_mm", 0.0) << ","
       << r.value("offset_change_mm", 0.0) << "," << r.value("time_utc", "") << "\n";
  base::AppendRecord(path.string(),
                     "job_id,machine,feature,status,size_mm,error_mm,offset_change_mm,time_utc\n",
                     line.str());
}

}  // namespace

nc::ToolOffsetChange ResolveToolChange(const ControllerConfig& c,
                                       int offset,
                                       nc::ToolRegister reg,
                                       double change_mm,
                                       std::string* note) {
  if (c.kind != ControllerConfig::Kind::kLinuxCnc) return {offset, reg, 0.0, change_mm, true};
  return nc::ResolveOnTable(nc::LoadToolTable(c.tool_table), c.tool_table, offset, reg, change_mm,
                            note);
}

std::string ControllerFile(const ControllerConfig& c,
                           const std::string& machine,
                           std::int64_t job) {
  const std::string stem = machine + "-job" + std::to_string(job);
  const fs::path dir(c.result_dir);
  if (c.kind == ControllerConfig::Kind::kLinuxCnc) return (dir / "mlp_result.ngc").string();
  if (c.kind == ControllerConfig::Kind::kFanucStyle) return (dir / (stem + ".nc")).string();
  return (dir / (stem + ".json")).string();
}

bool WritesReachedController(const ControllerConfig& c,
                             const std::string& machine,
                             std::int64_t job,
                             const std::vector<nc::ToolOffsetChange>& tool_changes) {
  try {
    if (c.kind == ControllerConfig::Kind::kLinuxCnc && c.write_tool_table &&
        !tool_changes.empty()) {
      return nc::TableHolds(nc::LoadToolTable(c.tool_table), tool_changes);
    }
    std::ifstream in(ControllerFile(c, machine, job));
    const std::string text{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
    if (c.kind == ControllerConfig::Kind::kFiles) {  // the result JSON names its job
      const auto result = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
      return result.is_object() && result.value("job_id", std::int64_t{-1}) == job;
    }
    return text.find("mlprobe job " + std::to_string(job) + ":") != std::string::npos;
  } catch (const std::exception&) {
    return false;
  }
}

WrittenFiles WriteResult(const ControllerConfig& c,
                         const nc::ToolChangeLimits& limits,
                         const std::string& machine,
                         std::int64_t job,
                         const nc::NcResult& r,
                         const nlohmann::json& result) {
  const fs::path dir(c.result_dir);
  fs::create_directories(dir);
  const std::string stem = machine + "-job" + std::to_string(job);
  WrittenFiles written;
  // The controller's file first: if it cannot be written, nothing else claims a result.
  if (c.kind == ControllerConfig::Kind::kLinuxCnc) {
    const fs::path p = dir / "mlp_result.ngc";
    base::WriteFileAtomically(p.string(), nc::LinuxCncSubroutine("mlp_result", r));
    written.files.push_back(p.string());
    if (c.write_tool_table && !r.tools.empty()) {
      const auto u = nc::UpdateToolTable(c.tool_table, nc::ToolUpdatesOf(r.tools), limits,
                                         "job " + std::to_string(job) + " on " + machine);
      written.files.push_back(c.tool_table);
      written.files.push_back(u.log_file);
      // The history holds the same before / after; a full disk here is said, not fatal.
      if (!u.log_error.empty()) written.warnings.push_back(u.log_error);
    }
  } else if (c.kind == ControllerConfig::Kind::kFanucStyle) {
    const fs::path p = dir / (stem + ".nc");
    base::WriteFileAtomically(p.string(), nc::FanucStyleSnippet(c.map, r));
    written.files.push_back(p.string());
  }
  const fs::path json_path = dir / (stem + ".json");
  base::WriteFileAtomically(json_path.string(), DumpSafe(result, 2) + "\n");
  written.files.push_back(json_path.string());
  AppendCsv(dir / "results.csv", result);
  written.files.push_back((dir / "results.csv").string());
  return written;
}

}  // namespace mlp::service
