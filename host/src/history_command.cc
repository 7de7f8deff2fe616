#include "mlp/host/history_command.h"

#include "mlp/history/history.h"
#include "mlp/host/cli.h"

#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <ostream>

namespace mlp::host {
namespace {

constexpr const char* kUsage =
    "usage: mlp history [--db FILE] [--machine M] [--kind K] [--since ISO8601] [--limit N]\n"
    "                   [--format text|csv|json] [--job N]\n"
    "  the database: --db, else $MLP_HISTORY, else /var/lib/mlprobe/history.sqlite\n"
    "exit codes: 0 listed, 2 bad arguments or no such database or job, 1 bug\n";
constexpr const char* kDefaultDb = "/var/lib/mlprobe/history.sqlite";

struct Options {
  std::string db, format = "text";
  history::JobFilter filter;
  long long job = 0;
};

long long Whole(const std::string& flag, const std::string& v) {
  char* end = nullptr;
  const long long n = std::strtoll(v.c_str(), &end, 10);
  if (end == v.c_str() || *end != '\0' || n < 1) throw UsageError(flag + " is a whole number >= 1");
  return n;
}

Options Parse(const std::vector<std::string>& args) {
  Options o;
  for (size_t i = 0; i < args.size(); ++i) {
    if (i + 1 >= args.size()) throw UsageError(args[i] + " needs a value");
    const std::string& k = args[i];
    const std::string v = args[++i];
    if (k == "--db")
      o.db = v;
    else if (k == "--machine")
      o.filter.machine = v;
    else if (k == "--kind")
      o.filter.kind = v;
    else if (k == "--since")
      o.filter.since_utc = v;
    else if (k == "--limit")
      o.filter.limit = static_cast<int>(std::min(Whole(k, v), 1000000LL));
    else if (k == "--job")
      o.job = Whole(k, v);
    else if (k == "--format" && (v == "text" || v == "csv" || v == "json"))
      o.format = v;
    else
      throw UsageError("unknown argument " + k + " " + v);
  }
  if (o.db.empty()) {
    const char* env = std::getenv("MLP_HISTORY");
    o.db = env && *env ? env : kDefaultDb;
  }
  // Reading must not create an empty database where the user mistyped a path.
  if (!std::filesystem::exists(o.db)) throw UsageError("no history database " + o.db);
  return o;
}

}  // namespace

int RunHistoryCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  try {
    const Options o = Parse(args);
    const history::History h(o.db);
    if (o.job > 0) {
      out << h.ExportJob(o.job).dump(2) << "\n";
      return kExitOk;
    }
    const auto jobs = h.ListJobs(o.filter);
    if (o.format == "csv") {
      out << history::JobsCsv(jobs);
    } else if (o.format == "json") {
      nlohmann::json a = nlohmann::json::array();
      for (const auto& j : jobs)
        a.push_back({{"id", j.id},
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
        out << std::setw(6) << j.id << "  " << j.started_utc << "  " << std::left << std::setw(10)
            << j.machine << std::setw(10) << j.kind << history::ToString(j.status) << std::right
            << "\n";
      out << jobs.size() << " job(s)\n";
    }
    return kExitOk;
  } catch (const UsageError& e) {
    err << "mlp history: " << e.what() << "\n" << kUsage;
  } catch (const history::HistoryError& e) {
    err << "mlp history: " << e.what() << "\n";
  } catch (const std::exception& e) {
    err << "mlp history: internal error: " << e.what() << "\n";
    return kExitInternal;
  }
  return kExitBadInput;
}

}  // namespace mlp::host
