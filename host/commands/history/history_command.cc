#include "mlp/host/history_command.h"

#include "mlp/base/files.h"
#include "mlp/history/history.h"
#include "mlp/host/cli.h"
#include "mlp/plant/database.h"

#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <ostream>

#include "history_commands.h"

namespace mlp::host {
namespace {

constexpr const char* kUsage =
    "usage: mlp history [--db FILE|URI] [--machine M] [--kind K] [--since ISO8601] [--limit N]\n"
    "                   [--host H] [--format text|csv|json] [--job N]\n"
    "       mlp history spc --feature F [--machine M] [--last N] [--svg FILE] [--json]\n"
    "                   [--db FILE|URI]\n"
    "  the jobs; or a measured feature's process capability over its last N parts (50): mean,\n"
    "  sigma within (moving range) and overall, Cp, Cpk, Pp, Ppk, control limits, and a run\n"
    "  chart as SVG, per nominal and limits\n"
    "  the database: --db, else $MLP_HISTORY, else /var/lib/mlprobe/history.sqlite; a\n"
    "  postgresql://... URI reads the plant's database (every host's jobs; --host H: one's)\n"
    "exit codes: 0 listed, 2 bad arguments or no such database or job, 3 no capability (no\n"
    "results, fewer than two, or no spread), 1 bug\n";
constexpr const char* kDefaultDb = "/var/lib/mlprobe/history.sqlite";

struct Options {
  std::string db, format = "text", host;
  history::JobFilter filter;
  long long job = 0;
};

Options Parse(const std::vector<std::string>& args) {
  const Args a(
      args, {{"--db", "--machine", "--kind", "--since", "--limit", "--job", "--format", "--host"}});
  Options o;
  o.db = a.Text("--db", "");
  if (a.Has("--machine")) o.filter.machine = a.Text("--machine");
  if (a.Has("--kind")) o.filter.kind = a.Text("--kind");
  if (a.Has("--since")) o.filter.since_utc = a.Text("--since");
  if (a.Has("--host")) o.filter.host = o.host = a.Text("--host");
  if (a.Has("--limit"))
    o.filter.limit = static_cast<int>(std::min(a.Integer("--limit", 0, 1), 1000000LL));
  o.job = a.Integer("--job", 0, 1);
  o.format = a.Text("--format", o.format);
  if (o.format != "text" && o.format != "csv" && o.format != "json")
    throw UsageError("--format is text, csv or json");
  return o;
}

}  // namespace

std::string HistoryDatabase(const std::string& given) {
  std::string db = given;
  if (db.empty()) {
    const char* env = std::getenv("MLP_HISTORY");
    db = env && *env ? env : kDefaultDb;
  }
  if (!std::filesystem::exists(db)) throw UsageError("no history database " + db);
  return db;
}

std::unique_ptr<history::JobRecords> OpenRecords(const std::string& given) {
  if (plant::IsDatabaseUri(given)) return std::make_unique<plant::PlantDatabase>(given);
  return std::make_unique<history::History>(HistoryDatabase(given));
}

int RunHistoryCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    if (!args.empty() && args[0] == "spc")
      return RunHistorySpc({args.begin() + 1, args.end()}, out, err);
    const Options o = Parse(args);
    const auto records = OpenRecords(o.db);
    if (o.job > 0) {
      out << records->ExportJob(o.job, o.host).dump(2) << "\n";
      return kExitOk;
    }
    const auto jobs = records->ListJobs(o.filter);
    if (o.format == "csv") {
      out << history::JobsCsv(jobs);
    } else if (o.format == "json") {
      nlohmann::json a = nlohmann::json::array();
      for (const auto& j : jobs)
        a.push_back({{"host", j.host},
                     {"id", j.id},
                     {"machine", j.machine},
                     {"kind", j.kind},
                     {"probe_serial", j.probe_serial},
                     {"calibration_id", j.calibration_id},
                     {"status", history::ToString(j.status)},
                     {"started_utc", j.started_utc},
                     {"finished_utc", j.finished_utc}});
      out << a.dump(2) << "\n";
    } else {
      for (const auto& j : jobs)
        out << (j.host.empty() ? "" : j.host + "  ") << std::setw(6) << j.id << "  "
            << j.started_utc << "  " << std::left << std::setw(10) << j.machine << std::setw(10)
            << j.kind << history::ToString(j.status) << std::right << "\n";
      out << jobs.size() << " job(s)\n";
    }
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp history: " << e.what() << "\n" << kUsage;
  } catch (const history::HistoryError& e) {
    err << "mlp history: " << e.what() << "\n";
  } catch (const base::FileError& e) {  // the run chart cannot be written
    err << "mlp history: " << e.what() << "\n";
  } catch (const std::exception& e) {
    err << "mlp history: internal error: " << e.what() << "\n";
    return kExitInternal;
  }
  return kExitBadInput;
}

}  // namespace mlp::host
