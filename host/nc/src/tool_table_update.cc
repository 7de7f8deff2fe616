#include "mlp/nc/tool_table_update.h"

#include "mlp/base/clock.h"
#include "mlp/base/csv.h"
#include "mlp/base/files.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <optional>
#include <set>
#include <sstream>

namespace mlp::nc {
namespace {

constexpr const char* kLogHeader =
    "time_utc,tool,tool_id,length_before_mm,length_after_mm,diameter_before_mm,"
    "diameter_after_mm,source\n";

[[noreturn]] void Refuse(const std::string& why) {
  throw ToolChangeRefused("tool table not changed: " + why);
}

[[noreturn]] void Fail(const std::string& why) {
  throw ToolTableError("tool table not changed: " + why);
}

// "T12"; appended, not `"T" + std::to_string(n)`: GCC 12 at -O3 warns falsely (-Wrestrict).
std::string ToolName(int tool) {
  std::string name(1, 'T');
  return name.append(std::to_string(tool));
}

std::string Mm(double v) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(5) << v;
  return s.str();
}

// One word: checked against the value decided on and the limit, then the new value.
double Checked(const ToolRecord& record,
               char word,
               const std::optional<double>& after,
               const std::optional<double>& decided_before,
               double max_change_mm,
               const char* unit = " mm") {
  const double now = record.Get(word);
  if (!after) return now;
  const std::string name = std::string(1, word) + " of " + ToolName(record.tool);
  if (!std::isfinite(*after)) Refuse(name + ": the new value is not finite");
  if (decided_before && std::abs(now - *decided_before) > kStaleToleranceMm)
    Refuse(name + " is " + Mm(now) + unit + ", not the " + Mm(*decided_before) + unit +
           " the change was decided on: the table changed in between");
  if (std::abs(*after - now) > max_change_mm)
    Refuse(name + ": the change " + Mm(now) + " -> " + Mm(*after) + unit + " is beyond " +
           Mm(max_change_mm) + unit + ": a wrong tool or a wrong number?");
  return *after;
}

std::string LogLine(const std::string& time, const ToolTableChange& c, const std::string& source) {
  std::ostringstream what;  // other words after the source: the log's columns stay as they were
  what << source;
  for (const auto& [word, values] : c.offsets)
    what << "; " << word << " " << Mm(values.first) << " -> " << Mm(values.second);
  return time + "," + std::to_string(c.tool) + "," + base::CsvField(c.tool_id) + "," +
         Mm(c.length_before_mm) + "," + Mm(c.length_after_mm) + "," + Mm(c.diameter_before_mm) +
         "," + Mm(c.diameter_after_mm) + "," + base::CsvField(what.str()) + "\n";
}

// The other offset words: each checked as Z is (rotary ones against their own limit in deg).
void CheckedOffsets(const ToolRecord& record,
                    const ToolUpdate& u,
                    const ToolChangeLimits& limits,
                    ToolTableChange* c) {
  static const std::string kWords = "XYABCUVW", kRotary = "ABC";
  for (const auto& [word, after] : u.offsets) {
    if (kWords.find(word) == std::string::npos)
      Fail(std::string(1, word) + " is not an offset word X Y A B C U V W of " + ToolName(u.tool));
    const auto before = u.offsets_before.find(word);
    const bool rotary = kRotary.find(word) != std::string::npos;
    const double value = Checked(
        record, word, after,
        before == u.offsets_before.end() ? std::nullopt : std::optional<double>(before->second),
        rotary ? limits.max_rotation_change_deg : limits.max_length_change_mm,
        rotary ? " deg" : " mm");
    c->offsets[word] = {record.Get(word), value};
  }
}

}  // namespace

std::string ToolChangeLogFor(const std::string& table_path) {
  const std::filesystem::path table(table_path);
  return (table.has_parent_path() ? table.parent_path() / "mlp-tool-changes.csv"
                                  : std::filesystem::path("mlp-tool-changes.csv"))
      .string();
}

std::string ToolTableLockFor(const std::string& table_path) {
  const std::filesystem::path table(table_path);
  std::string name(1, '.');  // appended piece by piece: GCC 12 -O3 false -Wrestrict on a + b
  name.append(table.filename().string()).append(".mlp-lock");
  return (table.parent_path() / name).string();
}

ToolTableUpdateResult UpdateToolTable(const std::string& table_path,
                                      const std::vector<ToolUpdate>& updates,
                                      const ToolChangeLimits& limits,
                                      const std::string& source) {
  // Read, change and write as one step against other writers of the same table (two machines
  // configured on one file, two hosts): without it one lane's write replaces the table the
  // other read, and its change is lost without a word.
  std::optional<base::FileLock> lock;
  try {
    lock.emplace(ToolTableLockFor(table_path));
  } catch (const base::FileError& e) {
    Fail(e.what());
  }
  ToolTable table = LoadToolTable(table_path);
  ToolTableUpdateResult result;
  std::set<int> seen;
  for (const ToolUpdate& u : updates) {
    if (!seen.insert(u.tool).second) Fail(ToolName(u.tool) + " is named twice");
    const auto record = table.Find(u.tool);
    if (!record) Fail(ToolName(u.tool) + " is not in " + table_path);
    ToolTableChange c{u.tool, u.tool_id, record->Get('Z'), 0, record->Get('D'), 0, {}};
    c.length_after_mm =
        Checked(*record, 'Z', u.length_mm, u.length_before_mm, limits.max_length_change_mm);
    c.diameter_after_mm =
        Checked(*record, 'D', u.diameter_mm, u.diameter_before_mm, limits.max_diameter_change_mm);
    CheckedOffsets(*record, u, limits, &c);
    if (u.length_mm) table.Set(u.tool, 'Z', c.length_after_mm);
    if (u.diameter_mm) table.Set(u.tool, 'D', c.diameter_after_mm);
    for (const auto& [word, values] : c.offsets) table.Set(u.tool, word, values.second);
    result.changes.push_back(c);
  }
  // The log must take the lines before the table changes: an empty record creates it (with its
  // header) or proves it writable; what can still fail after the table is written is a full disk.
  result.log_file = ToolChangeLogFor(table_path);
  try {
    base::AppendRecord(result.log_file, kLogHeader, "");
  } catch (const base::FileError& e) {
    Fail(std::string("its change log cannot be written: ") + e.what());
  }
  SaveToolTable(table, table_path);
  const std::string time = base::UtcTimestamp();
  std::string lines;  // one record: the lines of one update arrive together
  for (const ToolTableChange& c : result.changes) lines += LogLine(time, c, source);
  try {
    base::AppendRecord(result.log_file, kLogHeader, lines);
  } catch (const base::FileError& e) {
    result.log_error = std::string("the tool table is written but not logged: ") + e.what();
  }
  return result;
}

ToolOffsetChange ResolveOnTable(const ToolTable& table,
                                const std::string& source,
                                int tool,
                                ToolRegister reg,
                                double change_mm,
                                std::string* note) {
  const auto record = table.Find(tool);
  if (!record) throw ToolTableError("tool " + std::to_string(tool) + " is not in " + source);
  if (reg == ToolRegister::kLengthWear || reg == ToolRegister::kRadiusWear) {
    *note = "LinuxCNC has no wear registers: the " + ToString(reg) +
            " change is applied to the geometry value";
    reg = reg == ToolRegister::kLengthWear ? ToolRegister::kLengthGeometry
                                           : ToolRegister::kRadiusGeometry;
  }
  const double before_mm = record->Register(reg);
  return {tool, reg, before_mm, before_mm + change_mm, false};
}

std::vector<ToolUpdate> ToolUpdatesOf(const std::vector<ToolOffsetChange>& changes) {
  std::vector<ToolUpdate> updates;
  for (const ToolOffsetChange& t : changes) {
    auto u = std::find_if(updates.begin(), updates.end(),
                          [&](const ToolUpdate& x) { return x.tool == t.tool; });
    if (u == updates.end()) {
      ToolUpdate fresh;
      fresh.tool = t.tool;
      u = updates.insert(updates.end(), fresh);
    }
    if (const char word = OffsetWord(t.reg); word != 0) {
      u->offsets[word] = t.after_mm;
      u->offsets_before[word] = t.before_mm;
    } else if (t.reg == ToolRegister::kLengthGeometry || t.reg == ToolRegister::kLengthWear) {
      u->length_mm = t.after_mm;
      u->length_before_mm = t.before_mm;
    } else {  // the table holds the diameter
      u->diameter_mm = 2 * t.after_mm;
      u->diameter_before_mm = 2 * t.before_mm;
    }
  }
  return updates;
}

bool TableHolds(const ToolTable& table, const std::vector<ToolOffsetChange>& changes) {
  for (const ToolOffsetChange& t : changes) {
    const auto record = table.Find(t.tool);
    if (!record || t.incremental) return false;
    if (std::abs(record->Register(t.reg) - t.after_mm) > kStaleToleranceMm) return false;
  }
  return true;
}

}  // namespace mlp::nc
