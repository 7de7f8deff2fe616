#pragma once
// `mlp history`'s sub-commands, shared between its source files (not installed).

#include "mlp/history/history.h"

#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace mlp::host {

/// The history database: `given` (--db), else $MLP_HISTORY, else /var/lib/mlprobe's. Throws
/// UsageError when it does not exist (reading must not create an empty one where a path was
/// mistyped).
std::string HistoryDatabase(const std::string& given);

/// The jobs `given` names: the plant's PostgreSQL database for a postgresql:// URI, else a
/// history file (HistoryDatabase). Throws UsageError / HistoryError.
std::unique_ptr<history::JobRecords> OpenRecords(const std::string& given);

/// `mlp history spc ...` (history_spc.cc).
int RunHistorySpc(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mlp::host
