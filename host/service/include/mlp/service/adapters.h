#pragma once
/// @file Controller adapters: where offset changes and results go for each kind of controller
/// (docs/HOSTD.md). Every file is written whole or not at all (temporary file, fsync, rename);
/// the values before a change are read from the controller's own file where the host can see it
/// (LinuxCNC's tool table), else the change is written as an increment the control applies.

#include "mlp/nc/nc_output.h"
#include "mlp/nc/tool_table_update.h"
#include "mlp/service/config.h"

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace mlp::service {

/// The change `change_mm` of offset `offset` register `reg` as the controller takes it:
/// LinuxCNC: the tool table's value before (radius = D / 2, length = Z) and after; it has no
/// wear registers, so a wear change moves the geometry value (said in `note`). Fanuc-style and
/// files: an increment. Throws std::runtime_error (tool not in the table, unreadable table).
nc::ToolOffsetChange ResolveToolChange(const ControllerConfig& c,
                                       int offset,
                                       nc::ToolRegister reg,
                                       double change_mm,
                                       std::string* note);

/// Writes the job's result where the controller's macro and the shop's systems read it, and
/// returns the files written: always `<machine>-job<N>.json` (the result, for MES/SPC) and
/// `results.csv` (a line appended per job); LinuxCNC: `mlp_result.ngc`, the subroutine the macro
/// calls after its M-code (G10 lines and `#<_mlp_...>` parameters), and with `write_tool_table`
/// the tool table itself through nc::UpdateToolTable (within `limits`, the values decided on
/// still there, logged to `mlp-tool-changes.csv` beside it); Fanuc-style:
/// `<machine>-job<N>.nc` (G10 lines or macro variables, per the machine's map). Throws: nothing
/// after the failed file is written.
struct WrittenFiles {
  std::vector<std::string> files;     ///< in the order written
  std::vector<std::string> warnings;  ///< written, but something beside them was not (a log line)
};

WrittenFiles WriteResult(const ControllerConfig& c,
                         const nc::ToolChangeLimits& limits,
                         const std::string& machine,
                         std::int64_t job,
                         const nc::NcResult& nc_result,
                         const nlohmann::json& result);

/// The file that carries job `job`'s changes to the controller (written first by WriteResult):
/// LinuxCNC `mlp_result.ngc`, Fanuc-style `<machine>-job<N>.nc`, files `<machine>-job<N>.json`.
std::string ControllerFile(const ControllerConfig& c, const std::string& machine, std::int64_t job);

/// After a stop between a job's announced writes and their confirmation: did they reach the
/// controller? LinuxCNC with the host writing the tool table and tool changes announced: every
/// register there holds its `after_mm` (the table is what G43 applies, whichever job kind
/// wrote it). Otherwise: the controller file carries this job's header. Never throws (an
/// unreadable file means not written).
bool WritesReachedController(const ControllerConfig& c,
                             const std::string& machine,
                             std::int64_t job,
                             const std::vector<nc::ToolOffsetChange>& tool_changes);

}  // namespace mlp::service
