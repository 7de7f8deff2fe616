#pragma once
// The measure job (internal to mlp_service; hostd.cc runs it on the machine's turn).

#include "mlp/history/history.h"
#include "mlp/service/capture_broker.h"
#include "mlp/service/config.h"
#include "mlp/service/job_server.h"

#include <nlohmann/json.hpp>

namespace mlp::service {

struct JobContext {
  const HostdConfig& config;
  const MachineConfig& machine;
  history::History& history;
  Log log;
};

/// `{"op": "measure", "feature": "bore", "captures": [capture job ids], "nominal": {...},
/// "tolerance": {...}, "size": "ls"|"mic", "update": {...}}` (docs/HOSTD.md). Always answers;
/// the status says how the job ended. Nothing reaches the controller unless every check passed.
nlohmann::json RunMeasureJob(JobContext& ctx, const nlohmann::json& request);

}  // namespace mlp::service
