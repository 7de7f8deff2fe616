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

bool IsLength(nc::ToolRegister r) {
  return r == nc::ToolRegister::kLengthGeometry || r == nc::ToolRegister::kLengthWear;
}

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

// LinuxCNC's changes (absolute, with the values they were decided on) as the tool table's words:
// length Z, radius as the diameter D, the offsets X, Y, C; one update per tool.
std::vector<nc::ToolUpdate> ToolUpdates(const std::vector<nc::ToolOffsetChange>& changes) {
  std::vector<nc::ToolUpdate> updates;
  for (const nc::ToolOffsetChange& t : changes) {
    auto u = std::find_if(updates.begin(), updates.end(),
                          [&](const nc::ToolUpdate& x) { return x.tool == t.tool; });
    if (u == updates.end()) {
      nc::ToolUpdate fresh;
      fresh.tool = t.tool;
      u = updates.insert(updates.end(), fresh);
    }
    if (const char word = nc::OffsetWord(t.reg); word != 0) {
      u->offsets[word] = t.after_mm;
      u->offsets_before[word] = t.before_mm;
    } else if (t.reg == nc::ToolRegister::kLengthGeometry) {
      u->length_mm = t.after_mm;
      u->length_before_mm = t.before_mm;
    } else {
      u->diameter_mm = 2 * t.after_mm;
      u->diameter_before_mm = 2 * t.before_mm;
    }
  }
  return updates;
}

}  // namespace

nc::ToolOffsetChange ResolveToolChange(const ControllerConfig& c,
                                       int offset,
                                       nc::ToolRegister reg,
                                       double change_mm,
                                       std::string* note) {
  nc::ToolOffsetChange t{offset, reg, 0.0, change_mm, true};
  if (c.kind != ControllerConfig::Kind::kLinuxCnc) return t;
  const nc::ToolTable table = nc::LoadToolTable(c.tool_table);
  const auto tool = table.Find(offset);
  if (!tool)
    throw nc::ToolTableError("tool " + std::to_string(offset) + " is not in " + c.tool_table);
  if (reg == nc::ToolRegister::kLengthWear || reg == nc::ToolRegister::kRadiusWear) {
    *note = "LinuxCNC has no wear registers: the " + nc::ToString(reg) +
            " change is applied to the geometry value";
    reg = IsLength(reg) ? nc::ToolRegister::kLengthGeometry : nc::ToolRegister::kRadiusGeometry;
  }
  t.reg = reg;
  t.incremental = false;
  t.before_mm = tool->Register(reg);
  t.after_mm = t.before_mm + change_mm;
  return t;
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
      const nc::ToolTable table = nc::LoadToolTable(c.tool_table);
      for (const nc::ToolOffsetChange& t : tool_changes) {
        const auto tool = table.Find(t.tool);
        if (!tool || t.incremental) return false;
        // The table holds 4+ decimals; a value written is read back within 1e-6 mm.
        if (std::abs(tool->Register(t.reg) - t.after_mm) > 1e-6) return false;
      }
      return true;
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
      const auto u = nc::UpdateToolTable(c.tool_table, ToolUpdates(r.tools), limits,
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
