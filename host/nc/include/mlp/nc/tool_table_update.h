#pragma once
/// @file The one way mlprobe changes a LinuxCNC tool table: the service's jobs and
/// `mlp tool measure` both go through UpdateToolTable. It reads the table once, checks every
/// change, sets them all, replaces the file whole (SaveToolTable: temporary, fsync, rename) and
/// appends one line per tool to the audit log beside the table, before and after.

#include "mlp/nc/tool_table.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace mlp::nc {

/// A change the checks refuse: beyond the limit, not finite, or decided on a value the table no
/// longer holds. (Plain ToolTableError: the table or its log cannot be read or written, or a
/// tool is not in it.)
class ToolChangeRefused : public ToolTableError {
 public:
  using ToolTableError::ToolTableError;
};

/// One tool's new length (Z) and/or diameter (D), in the table's units (mm), and other offset
/// words (X, Y, A, B, C, U, V, W: an EDM electrode put back after re-clamping; degrees for the
/// rotary A, B, C).
struct ToolUpdate {
  int tool = 0;
  std::string tool_id;  ///< what the caller calls the tool, for the log only (may be empty)
  std::optional<double> length_mm, diameter_mm;
  /// The values the decision was made on. The table must still hold them (within
  /// kStaleToleranceMm), or someone changed it in between and the update is refused. Unset: the
  /// decision did not read the table (`mlp tool measure` measures the absolute value).
  std::optional<double> length_before_mm, diameter_before_mm;
  /// Other words' new values and the values they were decided on (each word in both).
  std::map<char, double> offsets{}, offsets_before{};
};

/// Machine safety: no single update moves a value further than this.
struct ToolChangeLimits {
  double max_length_change_mm = 0.5;  ///< also the linear offsets X, Y, U, V, W
  double max_diameter_change_mm = 0.5;
  double max_rotation_change_deg = 1.0;  ///< the rotary offsets A, B, C
};

/// What was written, per tool: the values before and after (an unchanged word: before = after).
struct ToolTableChange {
  int tool = 0;
  std::string tool_id;
  double length_before_mm = 0, length_after_mm = 0;
  double diameter_before_mm = 0, diameter_after_mm = 0;
  std::map<char, std::pair<double, double>> offsets{};  ///< other words: before, after
};

struct ToolTableUpdateResult {
  std::vector<ToolTableChange> changes;
  std::string log_file;   ///< the audit log the changes were appended to
  std::string log_error;  ///< non-empty: the table is written but its log line is not (a full disk)
};

/// The table's value read back differs from the one decided on by more than this: the table
/// holds at least 4 decimals (LinuxCNC writes 6).
inline constexpr double kStaleToleranceMm = 1e-6;

/// The audit log beside `table_path`: `mlp-tool-changes.csv`, one line per tool changed
/// (time_utc, tool, tool_id, length and diameter before and after, source; other words' before
/// and after follow the source in its column, "X 0.00000 -> -0.03000": the columns stay those
/// of logs already on machines).
std::string ToolChangeLogFor(const std::string& table_path);

/// The lock file UpdateToolTable holds while it reads, changes and writes a table
/// (".<table>.mlp-lock" beside it): writers of one table take turns, threads and processes.
std::string ToolTableLockFor(const std::string& table_path);

/// Applies `updates` to the tool table at `table_path` as one change and logs it, `source`
/// saying who asked (a job, a folder of images). Nothing is written, the table and the log as
/// they were, when it throws: ToolChangeRefused for a value that is not finite or no longer the
/// one decided on, or a change beyond `limits`; ToolTableError for an unreadable table or log, a
/// tool not in the table or named twice.
ToolTableUpdateResult UpdateToolTable(const std::string& table_path,
                                      const std::vector<ToolUpdate>& updates,
                                      const ToolChangeLimits& limits,
                                      const std::string& source);

// ---- LinuxCNC's rules for offset registers, in one place ------------------------------------

/// The change `change_mm` of register `reg` of tool `tool` as LinuxCNC's table takes it: the
/// value before as the table holds it (ToolRecord::Register: a length is Z, a radius half of
/// D), absolute. LinuxCNC has no wear registers: a wear change moves the geometry value, said
/// in `note` (left empty otherwise). Throws ToolTableError when the tool is not in the table
/// (`source`: the table's file, for the message).
ToolOffsetChange ResolveOnTable(const ToolTable& table,
                                const std::string& source,
                                int tool,
                                ToolRegister reg,
                                double change_mm,
                                std::string* note);

/// Absolute register changes (with the values they were decided on) as the table's words, one
/// update per tool: a length Z, a radius the diameter D (twice the radius), the offsets X, Y, C.
std::vector<ToolUpdate> ToolUpdatesOf(const std::vector<ToolOffsetChange>& changes);

/// True when every change's register holds its `after_mm` in `table` (within
/// kStaleToleranceMm): how a restart tells that an interrupted write reached the table. An
/// incremental change or a tool not in the table: false.
bool TableHolds(const ToolTable& table, const std::vector<ToolOffsetChange>& changes);

}  // namespace mlp::nc
