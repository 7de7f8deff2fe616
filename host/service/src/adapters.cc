#include "mlp/service/adapters.h"

#include "mlp/base/files.h"
#include "mlp/nc/tool_table.h"
#include "mlp/service/request_json.h"

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

// One CSV line per job for SPC: appended whole (one write of one line).
void AppendCsv(const fs::path& path, const nlohmann::json& r) {
  const bool fresh = !fs::exists(path);
  std::ostringstream line;
  if (fresh) line << "job_id,machine,feature,status,size_mm,error_mm,offset_change_mm,time_utc\n";
  line << r.value("job_id", 0) << "," << r.value("machine", "") << "," << r.value("feature", "")
       << "," << r.value("status", "") << "," << r.value("size_mm", 0.0) << ","
       << r.value("error_mm", 0.0) << "," << r.value("offset_change_mm", 0.0) << ","
       << r.value("time_utc", "") << "\n";
  std::ofstream out(path, std::ios::app);
  out << line.str();
  out.flush();
  if (!out) throw std::runtime_error("cannot append to " + path.string());
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
    throw std::runtime_error("tool " + std::to_string(offset) + " is not in " + c.tool_table);
  if (reg == nc::ToolRegister::kLengthWear || reg == nc::ToolRegister::kRadiusWear) {
    *note = "LinuxCNC has no wear registers: the " + nc::ToString(reg) +
            " change is applied to the geometry value";
    reg = IsLength(reg) ? nc::ToolRegister::kLengthGeometry : nc::ToolRegister::kRadiusGeometry;
  }
  t.reg = reg;
  t.incremental = false;
  t.before_mm = IsLength(reg) ? tool->Get('Z') : tool->Get('D') / 2.0;
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
                             const nlohmann::json& tool_changes) {
  try {
    if (c.kind == ControllerConfig::Kind::kLinuxCnc && c.write_tool_table &&
        !tool_changes.empty()) {
      const nc::ToolTable table = nc::LoadToolTable(c.tool_table);
      for (const auto& t : tool_changes) {
        const auto tool = table.Find(t.at("tool").get<int>());
        const bool length = t.at("length").get<bool>();
        if (!tool) return false;
        const double now_mm = length ? tool->Get('Z') : tool->Get('D') / 2.0;
        // The table holds 4+ decimals; a value written is read back within 1e-6 mm.
        if (std::abs(now_mm - t.at("after_mm").get<double>()) > 1e-6) return false;
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

std::vector<std::string> WriteResult(const ControllerConfig& c,
                                     const std::string& machine,
                                     std::int64_t job,
                                     const nc::NcResult& r,
                                     const nlohmann::json& result) {
  const fs::path dir(c.result_dir);
  fs::create_directories(dir);
  const std::string stem = machine + "-job" + std::to_string(job);
  std::vector<std::string> files;
  // The controller's file first: if it cannot be written, nothing else claims a result.
  if (c.kind == ControllerConfig::Kind::kLinuxCnc) {
    const fs::path p = dir / "mlp_result.ngc";
    base::WriteFileAtomically(p.string(), nc::LinuxCncSubroutine("mlp_result", r));
    files.push_back(p.string());
    if (c.write_tool_table && !r.tools.empty()) {
      nc::ToolTable table = nc::LoadToolTable(c.tool_table);
      for (const nc::ToolOffsetChange& t : r.tools) {
        const bool length = t.reg == nc::ToolRegister::kLengthGeometry;
        table.Set(t.tool, length ? 'Z' : 'D', length ? t.after_mm : 2 * t.after_mm);
      }
      nc::SaveToolTable(table, c.tool_table);
      files.push_back(c.tool_table);
    }
  } else if (c.kind == ControllerConfig::Kind::kFanucStyle) {
    const fs::path p = dir / (stem + ".nc");
    base::WriteFileAtomically(p.string(), nc::FanucStyleSnippet(c.map, r));
    files.push_back(p.string());
  }
  const fs::path json_path = dir / (stem + ".json");
  base::WriteFileAtomically(json_path.string(), DumpSafe(result, 2) + "\n");
  files.push_back(json_path.string());
  AppendCsv(dir / "results.csv", result);
  files.push_back((dir / "results.csv").string());
  return files;
}

}  // namespace mlp::service
