#pragma once
/// @file `mlp history`: the job history (docs/HOSTD.md), listed or exported.
///   mlp history [--db FILE] [--machine M] [--kind K] [--since ISO8601] [--limit N]
///               [--format text|csv|json] [--job N]
/// The database: --db, else $MLP_HISTORY, else /var/lib/mlprobe/history.sqlite. --job N
/// exports one job whole (JSON: request, captures, results, offset writes).

#include <iosfwd>
#include <string>
#include <vector>

namespace mlp::host {

int RunHistoryCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
